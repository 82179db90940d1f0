"""lamina.resect(): the same plan as `lamina resect --json`, the parts as numpy, errors as
lamina.Error."""
import json
import subprocess

import numpy as np
import pytest

import lamina


def test_resect_matches_the_command_line_and_gives_the_parts(cli):
    r = lamina.resect(plane=((30, 0, 0), (1, 0, 0)), margin_mm=25)
    done = subprocess.run([cli, "resect", "--plane", "30,0,0:1,0,0", "--margin",
                           "25", "--json"], capture_output=True, text=True, check=True)
    cli = json.loads(done.stdout)
    for key in ("volumes_ml", "future_liver_remnant", "tumours", "structures_crossed",
                "remnant_pieces", "functional_remnant", "findings"):
        assert r[key] == cli[key], key
    parts = r["parts"]
    assert parts.dtype == np.int32 and parts.shape == r["parts_mask"].shape
    assert (parts == 1).sum() == r["voxels_by_centre"]["remnant"]
    assert (parts == 2).sum() == r["voxels_by_centre"]["resected"]
    # The remnant is the larger side, x < 30 mm: its voxels' mean x is left of the plane.
    m = r["parts_mask"]
    i = np.arange(parts.shape[2]) * m.spacing_mm[0] + m.origin_mm[0]
    assert (i[np.nonzero(parts == 1)[2]] < 30 + m.spacing_mm[0]).all()
    assert any("under the 25.0 mm" in f for f in r["findings"])


def test_resect_gives_the_functional_remnant_as_volumes():
    # The plane x = 5 mm divides the left portal branch and the left hepatic vein.
    r = lamina.resect(plane=((5, 0, 0), (1, 0, 0)))
    fr = r["functional_remnant"]
    assert fr["assessed"] == {"portal": True, "hepatic": True}
    function, parts = r["function"], r["parts"]
    assert function.shape == parts.shape
    assert ((function > 0) == (parts == 1)).all()
    voxel_ml = np.prod(r["parts_mask"].spacing_mm) / 1000
    # The lost volume: the remnant's share of its voxels by centre.
    share = (function > 1).sum() / (function > 0).sum()
    assert abs(share * fr["remnant_ml"] - fr["lost_ml"]) < 0.01
    assert fr["lost_ml"] > 0 and fr["functional_ml"] < fr["remnant_ml"]
    portal = r["territories"]["portal_vein"]
    assert ((portal > 0) == (parts > 0)).all()
    # Every branch's territory as the report counts it.
    tree = next(t for t in fr["trees"] if t["name"] == "portal_vein")
    for b in tree["branches"]:
        assert abs((portal == b["id"] + 1).sum() * voxel_ml - b["territory_ml"]) < 0.01


def test_resect_gives_couinauds_segments_when_asked():
    r = lamina.resect(plane=((5, 0, 0), (1, 0, 0)), segments=True)
    segments, parts = r["segments"], r["parts"]
    assert ((segments > 0) == (parts > 0)).all() and segments.max() <= 8
    voxel_ml = np.prod(r["parts_mask"].spacing_mm) / 1000
    for s in r["couinaud_segments"]["segments"]:
        assert abs((segments == s["segment"]).sum() * voxel_ml - s["volume_ml"]) < 0.01
    assert "segments" not in lamina.resect(plane=((5, 0, 0), (1, 0, 0)))
    assert r["couinaud_segments"]["placed_by"] == "vessels"


def test_resect_places_segments_by_the_atlas_when_asked():
    a = lamina.resect(plane=((5, 0, 0), (1, 0, 0)), segments="atlas")
    assert a["couinaud_segments"]["placed_by"] == "atlas"
    assert ((a["segments"] > 0) == (a["parts"] > 0)).all()
    assert sorted(set(a["segments"][a["segments"] > 0].ravel())) == list(range(1, 9))
    with pytest.raises(lamina.Error, match="segments='atlases'"):
        lamina.resect(plane=((5, 0, 0), (1, 0, 0)), segments="atlases")


def test_resect_takes_a_mask_with_named_structures():
    mask = lamina.phantom(carved_out=True)
    r = lamina.resect(mask, plane=((-30, 0, 0), (1, 0, 0)), labels=[1],
                      embed=[(2, "portal_vein"), (3, "tumour"), (4, "hepatic_veins")],
                      keep=(60, 0, 0), liver="cirrhosis")
    assert r["future_liver_remnant"]["threshold_percent"] == 40.0
    assert r["surface"]["remnant_side"] == "front"
    big = r["tumours"][0]
    assert big["side"] == "resected" and abs(big["margin_mm"] - 15.0) < 2.6  # a voxel's diagonal
    assert {c["name"] for c in r["structures_crossed"]} == {"portal_vein", "hepatic_veins"}


def test_resect_refuses_a_plane_that_misses_the_organ():
    with pytest.raises(lamina.Error, match="misses the organ") as e:
        lamina.resect(plane=((0, 0, 500), (0, 0, 1)))
    assert e.value.exit_code == 2
    with pytest.raises(lamina.Error, match="plane="):
        lamina.resect()


def test_resect_plans_a_model_from_its_own_surfaces():
    mask = lamina.phantom(carved_out=True)
    model = lamina.build_model(mask, label=1, embed=[(2, "portal_vein"), (3, "tumour")],
                               display_triangles=20000, structure_triangles=4000)
    a = lamina.resect(model, plane=((30.7, 0, 0), (1, 0, 0)))
    b = lamina.resect(mask, plane=((30.7, 0, 0), (1, 0, 0)), labels=[1],
                      embed=[(2, "portal_vein"), (3, "tumour")])
    assert "parts" not in a and "parts" in b
    for part in ("remnant", "resected"):
        assert abs(a["volumes_ml"][part] / b["volumes_ml"][part] - 1) < 0.01, part
    assert [t["side"] for t in a["tumours"]] == [t["side"] for t in b["tumours"]]
    # The model carries the portal tree: its functional remnant is the segmentation's.
    fa, fb = a["functional_remnant"], b["functional_remnant"]
    assert fa is not None and fb is not None
    assert fb["devascularized_ml"] > 10
    assert abs(fa["devascularized_ml"] - fb["devascularized_ml"]) < (
        0.05 * fb["devascularized_ml"] + 0.005 * b["volumes_ml"]["remnant"])
    with pytest.raises(lamina.Error, match="its own"):
        lamina.resect(model, plane=((30, 0, 0), (1, 0, 0)), labels=[1])
