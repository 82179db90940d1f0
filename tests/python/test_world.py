"""Worlds of several organs from Python (lamina.world_scene): the TotalSegmentator liver and
gallbladder tied in their bed, stepped, the gallbladder pulled, a blade dividing the ties, a
scalpel cutting the liver and a reset putting it back, the bodies' positions as views, a bad scene
refused in one line."""
import os

import numpy as np
import pytest

import lamina
from conftest import REPO, fetch_page, free_port, polydata_points, serve_in_thread

LABELS = os.path.join(REPO, "tests", "data", "liver_totalseg_example_3mm_labels.nii.gz")


def scene(**extra):
    s = {
        "bodies": [
            {"name": "liver",
             "model": {"input": LABELS, "build": {"label": 1, "display_triangles": 0}}},
            {"name": "gallbladder",
             "model": {"input": LABELS, "build": {"label": 4, "skin_vertices": 400,
                                                  "display_triangles": 0}},
             "tools": [{"point": [-81.97, -234.98, 357.20], "radius_mm": 8,
                        "grasp": {"pull_mm": [0, -24, -4], "pull_s": 0.3}}]},
        ],
        "attachments": [{"bodies": ["liver", "gallbladder"], "reach_mm": 3}],
        "contact": {"rest_overlap_tolerance_mm": 6},
    }
    s.update(extra)
    return s


def test_a_world_steps_its_bodies_and_the_ties_pull_the_liver():
    w = lamina.world_scene(scene())
    assert w.bodies == ["liver", "gallbladder"]
    assert w.ties()["total"] > 100
    x0 = np.array(w.x("liver"))
    assert not w.x("liver").flags.writeable
    np.testing.assert_array_equal(w.x("liver"), w.rest("liver"))
    st = w.step(300)  # the grasper's pull, 0.3 s
    assert abs(st["time_s"] - 0.3) < 1e-9 and not st["unstable"]
    names = [b["name"] for b in st["bodies"]]
    assert names == ["liver", "gallbladder"]
    gb = st["bodies"][1]
    assert gb["max_displacement_mm"] > 15.0
    # The bed's ties pull the liver after the gallbladder; held there and settled, the forces
    # between them are equal and opposite within 1% (issue 62's target; during the pull they
    # differ by what the step moved each side, docs/world.md).
    liver_moved = np.linalg.norm(np.array(w.x("liver")) - x0, axis=1).max()
    assert liver_moved > 2.0
    st = w.step(300)
    fa = np.array(st["bodies"][0]["attachment_force_mn"])
    fb = np.array(st["bodies"][1]["attachment_force_mn"])
    assert np.linalg.norm(fa) > 500.0
    assert np.linalg.norm(fa + fb) <= 0.01 * np.linalg.norm(fa)
    f = w.skin_faces("gallbladder")
    assert f.shape[1] == 3 and f.max() < w.x("gallbladder").shape[0]
    w.reset()
    assert w.time_s == 0.0 and w.ties()["divided"] == 0


def test_a_dissection_divides_the_ties_it_passes():
    blade = {"path": [[-84.9, -252.2, 368.2], [-79.1, -188.2, 340.6]],
             "direction": [0.867, 0.129, 0.482], "depth_mm": 46, "start_s": 0.0,
             "end_s": 0.05, "reach_mm": 40.0}
    w = lamina.world_scene(scene(dissections=[blade]))
    total = w.ties()["total"]
    st = w.step(60)
    assert st["ties"]["divided"] == total  # a blade reaching 40 mm passes every tie of the bed
    # The same blade 100 mm away, in front of the organs, divides none.
    away = dict(blade, path=[[x, y - 100.0, z] for x, y, z in blade["path"]])
    w = lamina.world_scene(scene(dissections=[away]))
    assert w.step(60)["ties"]["divided"] == 0


def test_a_scalpel_cuts_the_body_it_passes_and_a_reset_puts_it_back():
    w = lamina.world_scene(scene())
    view = w.x("liver")  # taken before the cut: it keeps showing the state before
    rest = np.array(w.rest("liver"))
    lo, hi = rest.min(0), rest.max(0)
    y, top = 0.5 * (lo[1] + hi[1]) + 0.37, hi[2] + 5.0
    path = [[lo[0] + 0.3 * (hi[0] - lo[0]), y, top], [lo[0] + 0.7 * (hi[0] - lo[0]), y, top]]
    with pytest.raises(lamina.Error):
        w.cut(path[:1], 20.0, [0, 0, -1])
    assert w.topology("liver") == 0
    r = w.cut(path, 5.0 + 0.5 * (hi[2] - lo[2]), [0, 0, -1])
    assert r["bodies"]["liver"]["cut_tets"] > 0 and r["skipped"] == ""
    assert w.topology("liver") == 1 and len(w.x("liver")) > len(rest)
    assert len(w.rest("liver")) == len(w.x("liver"))
    assert w.skin_faces("liver").max() < len(w.x("liver"))
    np.testing.assert_array_equal(view, rest)
    st = w.step(200)
    assert not st["unstable"] and np.isfinite(w.x("liver")).all()
    assert st["ties"]["torn"] == 0
    w.reset()
    assert w.topology("liver") == 2 and len(w.x("liver")) == len(rest)
    np.testing.assert_array_equal(w.x("liver"), rest)


def test_a_bad_world_scene_is_one_line():
    with pytest.raises(lamina.Error) as e:
        lamina.world_scene({"bodies": [{"name": "liver"}],
                            "attachments": [{"bodies": ["liver", "stomach"]}]})
    assert "attachments[0].bodies[1]: no body is named \"stomach\"" in str(e.value)
    assert "\n" not in str(e.value) and e.value.exit_code == 2
    w = lamina.world_scene(scene())
    with pytest.raises(lamina.Error):
        w.x("spleen")


def test_a_world_is_served_over_openigtlink_and_to_the_web_page():
    # World.serve: the scene's world made again at rest and stepped in real time, each body's
    # skin a POLYDATA named after it, and the page (the library's network edge, as `lamina serve
    # SCENE --web`).
    w = lamina.world_scene(scene())
    port, web_port = free_port(), free_port()
    t, out = serve_in_thread(w, port=port, web=True, web_port=web_port, web_token="w0rld",
                             duration_s=4.0)
    points = polydata_points(port, {"liver", "gallbladder"})
    page = fetch_page(web_port, "w0rld", t)
    t.join(120)
    assert out.get("code") == 0, out
    assert points["liver"] > points["gallbladder"] > 100, points
    assert page is not None and "<html" in page.lower()
    assert w.time_s == 0.0  # this World was not stepped


def test_a_sweep_presses_a_body_changes_its_material_and_takes_a_cut_back():
    # A researcher's script: a tool on the liver's top, the liver made four times as stiff
    # between steps (its dent shrinks), a scalpel stroke, then World.undo_cut(): the liver as it
    # was just before the stroke, with the material of now.
    s = scene()
    del s["bodies"][1]["tools"]
    w = lamina.world_scene(s)
    rest = np.array(w.rest("liver"))
    top = int(np.argmax(rest[:, 2]))
    w.add_tool("liver", vertex=top, force_mn=[0, 0, -300])
    st = w.step(600)
    assert not st["unstable"]
    soft = rest[top, 2] - w.x("liver")[top, 2]
    assert soft > 0.5, soft
    assert w.reaction_force_mn("liver")[2] > 100.0  # the tissue pushes the tool back up
    e = w.material("liver")["young_modulus_kpa"]
    assert e > 0
    with pytest.raises(lamina.Error) as bad:
        w.set_material("liver", poisson_ratio=0.7)
    assert "poisson" in str(bad.value) and "\n" not in str(bad.value)
    assert w.material("liver")["poisson_ratio"] < 0.5  # nothing changed
    w.set_material("liver", young_modulus_kpa=4 * e)
    w.step(600)
    stiff = rest[top, 2] - w.x("liver")[top, 2]
    assert 0.0 < stiff < 0.6 * soft, (soft, stiff)

    w.clear_tools("liver")
    before = np.array(w.x("liver"))
    lo, hi = rest.min(0), rest.max(0)
    y, up = 0.5 * (lo[1] + hi[1]) + 0.37, hi[2] + 5.0
    path = [[lo[0] + 0.3 * (hi[0] - lo[0]), y, up], [lo[0] + 0.7 * (hi[0] - lo[0]), y, up]]
    assert w.cut(path, 5.0 + 0.5 * (hi[2] - lo[2]), [0, 0, -1])["bodies"]["liver"]["cut_tets"] > 0
    w.step(50)
    t = w.time_s
    w.set_material("liver", young_modulus_kpa=2 * e)
    undone = w.undo_cut()
    assert undone["bodies"] == ["liver"] and undone["ties_joined"] >= 0
    assert w.topology("liver") == 2 and len(w.x("liver")) == len(rest)
    np.testing.assert_array_equal(w.x("liver"), before)
    assert w.time_s == t and w.material("liver")["young_modulus_kpa"] == 2 * e
    assert not w.step(50)["unstable"]
    with pytest.raises(lamina.Error) as none:
        w.undo_cut()
    assert "no cut to undo" in str(none.value)
    w.reset()
    assert w.topology("liver") == 2  # nothing cut since: nothing put back
    np.testing.assert_array_equal(w.x("liver"), rest)
