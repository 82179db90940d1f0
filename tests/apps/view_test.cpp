// The viewer and the pictures, end to end with the real binary: `lamina view` under Xvfb driven
// by its scripted input and by real X events (xdotool), `lamina render` with no display at all,
// and `lamina figures` writing every file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "support/run_cli.h"
#include "support/temp_dir.h"
#include "support/test_paths.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::quoted;

constexpr const char* kXvfb = "xvfb-run -a -s '-screen 0 1600x1000x24' ";

// Runs a shell command from a script file in `dir` (no nested quoting).
test::RunResult run_shell(const test::TempDir& dir, const std::string& command,
                          const std::string& name = "command.sh") {
  std::ofstream(dir.path / name) << command << "\n";
  return test::run_cli("/bin/sh", dir.path, dir.path, name);
}

// `lamina view` (its quit.json script, report.json) under Xvfb, sent real X events: once its
// window is seen, xdotool runs `moves` on it ($w). -v: the viewer's debug log says what each
// press did (and why it started no drag), so that a failure shows its cause. The window is
// probed hidden: before, xdotool could find a probe window that vanished a moment later and send
// its events nowhere (BadWindow).
test::RunResult run_with_xdotool(const test::TempDir& dir, const std::string& moves) {
  std::ofstream(dir.path / "session.sh")
      << quoted(test::lamina_cli()) +
             " -v view --rate 1000 --script quit.json --report report.json & " +
             "w=$(xdotool search --sync --onlyvisible --name Lamina | head -n 1); sleep 1; "
             "xdotool " +
             moves + "; wait\n";
  return run_shell(dir, std::string(kXvfb) + "sh session.sh");
}

bool is_png(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  char sig[4] = {};
  in.read(sig, 4);
  return in && sig[1] == 'P' && sig[2] == 'N' && sig[3] == 'G';
}

TEST(View, ScriptedDragMovesTheSkinAndReleaseLetsItReturn) {
  test::TempDir dir;
  std::ofstream(dir.path / "drag.json") << R"({"events": [
    {"at": 0.5, "mouse": [0.5, 0.5]},
    {"at": 0.7, "press": "left"},
    {"at": 0.8, "mouse": [0.5, 0.35], "over": 0.2},
    {"at": 1.1, "wait": {"simulated_s": 0.4}},
    {"at": 1.2, "screenshot": "dragged.png"},
    {"at": 1.3, "release": "left"},
    {"at": 1.4, "wait": {"simulated_s": 0.5}},
    {"at": 1.5, "quit": true}]})";
  const auto r = run_shell(dir, std::string(kXvfb) + quoted(test::lamina_cli()) +
                                    " view --rate 1000 --script drag.json --report report.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json rep = json::parse(test::read_text(dir.path / "report.json"));
  EXPECT_EQ(rep["drags"], 1);
  // How many frames and steps a machine gives is its own (lamina bench measures speed): here the
  // window drew (the screenshot below is a frame after the drag), the simulation thread stepped,
  // and the report says honestly how it kept up, as in RealMouseEventsFromXdotoolDragTheOrgan.
  EXPECT_GT(rep["frames"].get<int>(), 0) << "the window did not draw";
  EXPECT_GT(rep["sim_steps"].get<int>(), 0) << "the simulation thread did not run";
  const double rtf = rep["real_time_factor"].get<double>();
  ASSERT_GT(rep["min_real_time_factor"].get<double>(), 0.0) << "real time not measured";
  EXPECT_NEAR(rep["achieved_rate_hz"].get<double>() * rep["dt_s"].get<double>(), rtf, 0.02 * rtf)
      << "the simulated clock is not the steps taken";
  EXPECT_EQ(rep["fell_behind"].get<bool>(), rep["min_real_time_factor"].get<double>() < 0.95);
  EXPECT_EQ(r.err.find("fell behind real time") != std::string::npos,
            rep["fell_behind"].get<bool>())
      << r.err;
  // The drag is held 0.4 simulated seconds however slowly this machine steps (the script waits
  // for the simulation's clock; the input is trickled, so even a frame of a second sees the press
  // where it was): 10 mm here, and the same on a sanitized machine that falls behind.
  EXPECT_GT(rep["max_displacement_mm"].get<double>(), 5.0) << "the drag did not move the skin\n"
                                                           << rep.dump();
  EXPECT_LT(rep["final_max_displacement_mm"].get<double>(),
            0.8 * rep["max_displacement_mm"].get<double>())
      << "the organ did not start back to rest after release\n"
      << rep.dump();
  EXPECT_EQ(rep["recoveries"], 0);
  EXPECT_TRUE(is_png(dir.path / "dragged.png"));
  EXPECT_FALSE(fs::exists(dir.path / "imgui.ini")) << "stray file";
}

// A world scene (issue 62): the cholecystectomy's liver and gallbladder, tied in its bed, both
// drawn and stepping in one world at the rate the machine keeps, the scene's grasper and blades
// playing; the report says what it kept and what the blades divided.
TEST(View, TheCholecystectomyWorldIsShownInRealTimeAtTheRateTheMachineKeeps) {
  test::TempDir dir;
  std::ofstream(dir.path / "world.json") << R"({"events": [
    {"at": 5.0, "window_screenshot": "world.png"},
    {"at": 6.0, "quit": true}]})";
  const auto r =
      run_shell(dir, std::string(kXvfb) + quoted(test::lamina_cli()) + " view " +
                         quoted(test::source_path("examples/cholecystectomy.json").string()) +
                         " --script world.json --report report.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json rep = json::parse(test::read_text(dir.path / "report.json"));
  EXPECT_TRUE(rep["world"].get<bool>());
  ASSERT_EQ(rep["bodies"].size(), 2u);
  EXPECT_EQ(rep["bodies"][0]["name"], "liver");
  EXPECT_EQ(rep["bodies"][1]["name"], "gallbladder");
  EXPECT_GT(rep["attachments"]["total"].get<int>(), 100);
  EXPECT_GT(rep["frames"].get<int>(), 0);
  EXPECT_GT(rep["steps"].get<int>(), 0) << "the world's thread did not step";
  EXPECT_TRUE(rep["auto_rate"].get<bool>());
  EXPECT_NEAR(rep["dt_s"].get<double>(), 1.0 / rep["rate_hz"].get<double>(), 1e-12)
      << "dt follows the rate: the simulated clock follows the wall clock";
  EXPECT_EQ(r.err.find("fell behind real time") != std::string::npos,
            rep["fell_behind"].get<bool>())
      << r.err;
  EXPECT_EQ(rep["unstable_events"], 0);
  // The grasper retracts the fundus (24 mm over 1 s of simulated time): it moved.
  EXPECT_GT(rep["bodies"][1]["max_displacement_mm"].get<double>(), 1.0);
  EXPECT_TRUE(is_png(dir.path / "world.png"));
}

// Real time by default (issue 48): given no --rate, the viewer measures its steps and moves to
// the highest rate of 1000, 500, 250, 120, 60 Hz it keeps, says so in the log and the report. A
// 10k-node phantom does not keep 1 kHz on these machines (1,000 steps/s would need 1 ms steps:
// 136 steps/s measured, docs/benchmarks.md), so it must come down.
TEST(View, WithoutARateItStepsAtARateTheMachineKeeps) {
  test::TempDir dir;
  std::ofstream(dir.path / "big.json")
      << R"({"model": {"input": "phantom", "build": {"skin_vertices": 5000}}})";
  std::ofstream(dir.path / "quit.json") << R"({"events": [{"at": 7.0, "quit": true}]})";
  const auto r = run_shell(dir, std::string(kXvfb) + quoted(test::lamina_cli()) +
                                    " view big.json --script quit.json --report report.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json rep = json::parse(test::read_text(dir.path / "report.json"));
  EXPECT_TRUE(rep["auto_rate"].get<bool>());
  const double rate = rep["rate_hz"].get<double>();
  EXPECT_LT(rate, 1000.0) << r.err;
  EXPECT_TRUE(rate == 500.0 || rate == 250.0 || rate == 120.0 || rate == 60.0) << rate;
  EXPECT_NE(r.err.find("stepping at"), std::string::npos) << r.err;
  EXPECT_NEAR(rep["dt_s"].get<double>(), 1.0 / rate, 1e-9) << "dt follows the rate";

  // --rate forces one: kept, however far behind.
  const auto forced =
      run_shell(dir,
                std::string(kXvfb) + quoted(test::lamina_cli()) +
                    " view big.json --rate 1000 --script quit.json --report forced.json",
                "forced.sh");
  ASSERT_EQ(forced.exit_code, 0) << forced.err;
  const json f = json::parse(test::read_text(dir.path / "forced.json"));
  EXPECT_FALSE(f["auto_rate"].get<bool>());
  EXPECT_EQ(f["rate_hz"].get<double>(), 1000.0);
  EXPECT_EQ(forced.err.find("stepping at"), std::string::npos) << forced.err;
}

// A case built to explode: the paper's soft springs dragged with a thousand times the default
// gain (hundreds of newtons) pull the skin farther than the organ is wide. The window says so,
// the simulation stops, the log and the report say so, and the viewer's exit code is 5.
TEST(View, ADragThatBlowsTheOrganUpIsShownLoggedAndEndsWithExitFive) {
  test::TempDir dir;
  std::ofstream(dir.path / "blow.json") << R"({"events": [
    {"at": 0.5, "mouse": [0.5, 0.5]},
    {"at": 0.7, "press": "left"},
    {"at": 0.8, "mouse": [0.5, 0.25], "over": 0.5},
    {"at": 3.5, "window_screenshot": "blown.png"},
    {"at": 4.0, "quit": true}]})";
  const auto r =
      run_shell(dir, std::string(kXvfb) + quoted(test::lamina_cli()) +
                         " view --rate 1000 --paper --gain 10 --script blow.json --report "
                         "report.json");
  EXPECT_EQ(r.exit_code, 5) << r.err;
  EXPECT_NE(r.err.find("error: lamina view: the simulation became unstable at t = "),
            std::string::npos)
      << r.err;
  const json rep = json::parse(test::read_text(dir.path / "report.json"));
  EXPECT_EQ(rep["unstable_events"], 1);
  EXPECT_NE(rep["first_unstable_reason"].get<std::string>().find("steps failed"),
            std::string::npos);
  EXPECT_TRUE(is_png(dir.path / "blown.png"));
}

TEST(View, RebuildSwapsTheModelUnderTheRunningSimulation) {
  test::TempDir dir;
  // The rebuild takes as long as this machine needs (3-4x longer under the sanitizers): the
  // script's clock waits for the new model, and the drag follows it.
  std::ofstream(dir.path / "rebuild.json") << R"({"events": [
    {"at": 0.3, "rebuild": {"layers": 3, "skin_vertices": 800}},
    {"at": 0.3, "wait": "rebuild"},
    {"at": 0.6, "mouse": [0.5, 0.5]},
    {"at": 0.8, "press": "left"},
    {"at": 0.9, "mouse": [0.5, 0.4], "over": 0.5},
    {"at": 1.5, "wait": {"simulated_s": 0.4}},
    {"at": 2.1, "release": "left"},
    {"at": 2.6, "quit": true}]})";
  const auto r = run_shell(dir, std::string(kXvfb) + quoted(test::lamina_cli()) +
                                    " view --rate 1000 --script rebuild.json --report report.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json rep = json::parse(test::read_text(dir.path / "report.json"));
  EXPECT_EQ(rep["rebuilds"], 1) << "the rebuild did not finish before the drag";
  EXPECT_EQ(rep["layers"], 3);
  EXPECT_EQ(rep["drags"], 1) << "dragging the rebuilt model failed";
  EXPECT_GT(rep["max_displacement_mm"].get<double>(), 1.0) << rep.dump();
}

TEST(View, RealMouseEventsFromXdotoolDragTheOrgan) {
  // The default scene, the physical liver, as a user meets it: a real drag of about 110 pixels
  // dents it where it is dragged, the simulation steps 1 ms at a time against the wall clock
  // (and says so if the machine cannot keep up), and 3 simulated seconds after the release the
  // organ is back at rest.
  test::TempDir dir;
  // The quit waits for the report's record of 3 simulated seconds after the release, however
  // long this machine takes to simulate them.
  std::ofstream(dir.path / "quit.json")
      << R"({"events": [{"at": 9.0, "wait": "settled"}, {"at": 9.0, "quit": true}]})";
  // The viewer waits for the X events; xdotool presses at the window's centre (the organ) and
  // drags upwards in steps, then lets go. The press is held a second before the drag, so that
  // a frame sees it at the centre even when a loaded machine draws only a few frames a second.
  const auto r = run_with_xdotool(
      dir,
      "mousemove --window $w 700 450 sleep 0.5 mousedown 1 sleep 1.0 "
      "mousemove --window $w 700 420 sleep 0.2 mousemove --window $w 700 380 sleep 0.2 "
      "mousemove --window $w 700 340 sleep 1.5 mouseup 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json rep = json::parse(test::read_text(dir.path / "report.json"));
  EXPECT_EQ(rep["drags"], 1) << "the press on the organ was not seen\n" << r.err;
  // The 2-second drag dents the organ by millimetres in real time. A machine that cannot keep up
  // (ASan with a build beside it ran 0.03x: 60 ms of simulated drag) dents it less, and says so
  // below; a dent is still required.
  EXPECT_GT(rep["max_displacement_mm"].get<double>(), rep["fell_behind"].get<bool>() ? 0.5 : 2.0);
  // A dent where it is dragged, not a swing of the whole organ: the largest displacement is at
  // (or next to) the dragged node.
  EXPECT_LT(rep["drag_peak_distance_from_drag_mm"].get<double>(), 15.0);
  EXPECT_DOUBLE_EQ(rep["dt_s"].get<double>(), 0.001);
  EXPECT_GE(rep["max_displacement_3s_after_release_mm"].get<double>(), 0.0) << "not measured";
  EXPECT_LT(rep["max_displacement_3s_after_release_mm"].get<double>(), 0.05);
  // Real time is the machine's to give (lamina bench measures it); the viewer's part is to step
  // 1 ms of simulated time per millisecond when it can, and to say so when it cannot: the report,
  // the rate and the closing message agree with each other.
  const double min_rtf = rep["min_real_time_factor"].get<double>();
  const double rtf = rep["real_time_factor"].get<double>();
  ASSERT_GT(min_rtf, 0.0) << "real time not measured";
  EXPECT_LE(min_rtf, rtf + 1e-9);
  EXPECT_NEAR(rep["achieved_rate_hz"].get<double>() * rep["dt_s"].get<double>(), rtf, 0.02 * rtf)
      << "the simulated clock is not the steps taken";
  EXPECT_EQ(rep["fell_behind"].get<bool>(), min_rtf < 0.95) << rep.dump();
  const bool said_so = r.err.find("fell behind real time") != std::string::npos;
  EXPECT_EQ(said_so, rep["fell_behind"].get<bool>()) << r.err;
  if (rep["fell_behind"].get<bool>())
    std::fprintf(stderr, "note: this machine kept %.2fx real time at worst\n", min_rtf);
}

TEST(View, RealMouseEventsFromXdotoolCutTheOrganInScalpelModeAndUUndoesIt) {
  // K, then a real drag across the organ: the release cuts it along the drag, then U undoes the
  // cut (the report counts the cuts in force and the model's nodes), and the organ, nothing
  // pulling it, stays at rest throughout.
  test::TempDir dir;
  std::ofstream(dir.path / "quit.json") << R"({"events": [{"at": 12.0, "quit": true}]})";
  const auto r = run_with_xdotool(
      dir,
      "mousemove --window $w 600 440 sleep 0.5 key k sleep 0.5 mousedown 1 sleep 1.0 "
      "mousemove --window $w 700 440 sleep 0.2 mousemove --window $w 800 440 sleep 0.2 "
      "mousemove --window $w 900 440 sleep 0.2 mousemove --window $w 1000 440 sleep 0.2 "
      "mousemove --window $w 1100 440 sleep 1.0 mouseup 1 sleep 2.0 key u sleep 1.0");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json rep = json::parse(test::read_text(dir.path / "report.json"));
  // The drag cut (the cut model adopted: the log says what it divided), then U took it back.
  EXPECT_NE(r.err.find("lamina view: cut "), std::string::npos) << "the drag did not cut\n"
                                                                << r.err;
  EXPECT_NE(r.err.find("lamina view: undid the last cut (0 in force)"), std::string::npos) << r.err;
  EXPECT_EQ(rep["cuts"], 0) << r.err;
  EXPECT_EQ(rep["nodes"].get<int>(), 2321) << "the model before the cut is not shown again";
  EXPECT_LT(rep["max_displacement_mm"].get<double>(), 0.5) << "the cut organ moved";
  EXPECT_EQ(rep["recoveries"], 0);
  EXPECT_EQ(rep["unstable_events"], 0);
}

TEST(View, RealMouseEventsFromXdotoolPlanAResectionAndPerformIt) {
  // The phantom with its anatomy embedded; P shows the resection plane, a Shift+drag on it turns
  // it, a drag moves it along its normal, the plan follows (the report's resection), and X
  // divides the organ along it with the simulated cut: two pieces, the plan's volumes; the
  // resected piece is taken away and a drag then dents the remnant, simulated on its own.
  test::TempDir dir;
  const std::string cli = quoted(test::lamina_cli());
  std::ofstream(dir.path / "prepare.sh")
      << cli << " phantom --carved-out -o p.nii.gz && " << cli
      << " build p.nii.gz --label 1 --embed 2=portal_vein,3=tumour,4=hepatic_veins -o m.vtu\n";
  ASSERT_EQ(run_shell(dir, "sh prepare.sh", "prepare_run.sh").exit_code, 0);
  // The script waits for what takes this machine's own time: after the planned picture it holds
  // until X's resection is done (cut, resected part gone, remnant in use) and then writes
  // resected.png, which the X events' script waits for before the drag on the remnant; the
  // remnant's picture and the quit follow that drag.
  std::ofstream(dir.path / "quit.json")
      << R"({"events": [{"at": 9.4, "window_screenshot": "planned.png"},)"
      << R"( {"at": 9.5, "wait": "resected"}, {"at": 9.6, "window_screenshot": "resected.png"},)"
      << R"( {"at": 14.0, "window_screenshot": "remnant.png"}, {"at": 14.8, "quit": true}]})";
  // The gestures read the mouse and Shift once a frame: each drag is held still for a second
  // before its release (and Shift after it), so that a slow frame (the first plan, or a
  // sanitizer's build) still sees the drag's end with Shift down.
  std::ofstream(dir.path / "session.sh")
      << cli << " -v view m.vtu --script quit.json --report report.json & "
      << "w=$(xdotool search --sync --onlyvisible --name Lamina | head -n 1); sleep 1.5; "
         "xdotool key --window $w p sleep 2.0 keydown shift mousemove --window $w 800 450 "
         "sleep 0.3 mousedown 1 sleep 0.2 mousemove --window $w 800 440 sleep 0.1 "
         "mousemove --window $w 800 430 sleep 0.1 mousemove --window $w 800 420 sleep 1.0 "
         "mouseup 1 sleep 0.5 keyup shift sleep 0.5 mousemove --window $w 800 450 sleep 0.3 "
         "mousedown 1 sleep 0.3 mousemove --window $w 840 450 sleep 0.1 mousemove --window $w 880 "
         "450 sleep 0.1 mousemove --window $w 920 450 sleep 1.0 mouseup 1 sleep 1.5 "
         "key --window $w x; "
         "n=0; while [ ! -s resected.png ] && [ $n -lt 1200 ]; do sleep 0.1; n=$((n+1)); done; "
         "sleep 0.5; xdotool mousemove --window $w 700 450 sleep 0.3 mousedown 1 "
         "sleep 0.3 mousemove --window $w 700 480 sleep 0.1 mousemove --window $w 700 510 "
         "sleep 0.1 mousemove --window $w 700 540 sleep 1.0 mouseup 1; wait\n";
  const auto r = run_shell(dir, std::string(kXvfb) + "sh session.sh");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json rep = json::parse(test::read_text(dir.path / "report.json"));
  const json& plan = rep["resection"];
  EXPECT_EQ(plan["moves"], 2) << "both presses should have met the plane\n" << r.err;
  // Turned away from the organ's long axis (x), and moved along it from its centre (x -2.5).
  EXPECT_LT(plan["normal"][0].get<double>(), 0.9995) << plan.dump();
  EXPECT_GT(plan["point_mm"][0].get<double>(), 10.0) << plan.dump();
  // The plan follows the plane while it moves: at least one plan for each drag besides the first
  // (a loaded machine's frames of a third of a second give 7; an idle one 18).
  EXPECT_GE(plan["updates"].get<int>(), 3) << plan.dump();
  EXPECT_TRUE(plan["resected"].get<bool>());
  EXPECT_EQ(plan["error"], "");
  // The model carries the portal and hepatic trees (issue 63): the plan's functional remnant is
  // at most its geometric one, and the skin is coloured by the territories (the last plan's).
  ASSERT_TRUE(plan.contains("functional_flr_percent")) << plan.dump();
  EXPECT_LE(plan["functional_flr_percent"].get<double>(), plan["flr_percent"].get<double>() + 1e-9);
  EXPECT_GE(plan["devascularized_ml"].get<double>(), 0.0);
  EXPECT_GT(plan["territory_triangles"].get<int>(), 1000) << plan.dump();
  // The cut divided the organ in two; its larger piece is the plan's remnant (the display skin's
  // volume against the tetrahedra's, which lie 1-2% inside it).
  const size_t at = r.err.find("lamina view: cut ");
  ASSERT_NE(at, std::string::npos) << r.err;
  EXPECT_NE(r.err.find("2 piece(s)", at), std::string::npos) << r.err.substr(at, 200);
  const double remnant = plan["remnant_ml"].get<double>();
  const double piece = std::stod(r.err.substr(r.err.find("piece(s): ", at) + 10));
  EXPECT_NEAR(piece, remnant, 0.03 * remnant);
  EXPECT_TRUE(is_png(dir.path / "planned.png"));
  // The resected piece is gone: the remnant alone is simulated (a model of its own, swapped in
  // as a rebuild is), and the drag after it dented it (the plane's drags moved no tissue).
  EXPECT_NE(plan["message"].get<std::string>().find("simulated on its own"), std::string::npos)
      << plan.dump();
  EXPECT_EQ(rep["rebuilds"], 1);
  EXPECT_EQ(rep["drags"], 1) << r.err;
  EXPECT_GT(rep["max_displacement_mm"].get<double>(), 1.0) << r.err;
  EXPECT_TRUE(is_png(dir.path / "remnant.png"));
  EXPECT_EQ(rep["unstable_events"], 0);
}

TEST(View, WithoutADisplaySaysSoAndSuggestsRender) {
  test::TempDir dir;
  const auto r =
      run_shell(dir, "env -u DISPLAY -u WAYLAND_DISPLAY " + quoted(test::lamina_cli()) + " view");
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_NE(r.err.find("no display"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("lamina render"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

TEST(View, BadScriptIsRejectedBeforeAnyWindow) {
  test::TempDir dir;
  std::ofstream(dir.path / "bad.json") << R"({"events": [{"at": 1, "press": "thumb"}]})";
  const auto r =
      run_shell(dir, std::string(kXvfb) + quoted(test::lamina_cli()) + " view --script bad.json");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("bad.json: events[0].press"), std::string::npos) << r.err;
  std::ofstream(dir.path / "wait.json")
      << R"({"events": [{"at": 1, "wait": {"simulated_s": -1}}]})";
  const auto w = run_shell(
      dir, std::string(kXvfb) + quoted(test::lamina_cli()) + " view --script wait.json", "wait.sh");
  EXPECT_EQ(w.exit_code, 2);
  EXPECT_NE(w.err.find("wait.json: events[0].wait: expected"), std::string::npos) << w.err;
}

TEST(Render, WritesAPictureWithNoDisplayAndRejectsBadOptions) {
  test::TempDir dir;
  auto r = run_shell(dir, "env -u DISPLAY " + quoted(test::lamina_cli()) +
                              " render phantom -o poke.png --at 0.8 --size 320x240");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(is_png(dir.path / "poke.png"));
  EXPECT_NE(r.out.find("1 tool(s) acting"), std::string::npos) << r.out;

  r = run_shell(dir, quoted(test::lamina_cli()) + " render phantom -o bad.png --camera 10,100");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--camera"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir.path / "bad.png"));
  r = run_shell(dir, quoted(test::lamina_cli()) + " render phantom -o picture.jpg");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_FALSE(fs::exists(dir.path / "picture.jpg"));
}

// Whether two files hold the same bytes (a PNG of the same picture is the same file).
bool same_file(const fs::path& a, const fs::path& b) {
  return test::read_text(a) == test::read_text(b);
}

TEST(Render, DrawsTheDisplaySkinAndStructuresAsAskedAndRefusesBadChoices) {
  test::TempDir dir;
  const std::string lamina = quoted(test::lamina_cli());
  auto r = run_shell(dir, lamina + " phantom --labels --spacing 3 -o ph.nii.gz && " + lamina +
                              " build ph.nii.gz --display-triangles 5000 --structure-triangles "
                              "3000 --embed 2=vessels,3=tumour -o m.vtu");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string render = "env -u DISPLAY " + lamina + " render m.vtu --size 240x180 -o ";
  for (const char* args :
       {"all.png", "named.png --structures vessels,tumour", "none.png --structures none",
        "vessels.png --structures vessels", "sim.png --structures none --display-skin off"}) {
    r = run_shell(dir, render + args);
    ASSERT_EQ(r.exit_code, 0) << args << ": " << r.err;
  }
  EXPECT_TRUE(same_file(dir.path / "all.png", dir.path / "named.png"));
  EXPECT_FALSE(same_file(dir.path / "all.png", dir.path / "none.png"));
  EXPECT_FALSE(same_file(dir.path / "all.png", dir.path / "vessels.png"));
  EXPECT_FALSE(same_file(dir.path / "none.png", dir.path / "vessels.png"));
  EXPECT_FALSE(same_file(dir.path / "none.png", dir.path / "sim.png"));

  r = run_shell(dir, render + "bad.png --display-skin maybe");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--display-skin: expected on or off"), std::string::npos) << r.err;
  r = run_shell(dir, render + "bad.png --structures liver");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no structure 'liver' (it has: vessels, tumour)"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir.path / "bad.png"));
}

TEST(Figures, QuickRunWritesEveryFigureAndItsData) {
  test::TempDir dir;
  const auto r = run_shell(dir, quoted(test::lamina_cli()) + " figures --quick -o figs");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* png :
       {"fig4_trajectories.png", "fig5_timing.png", "fig6_snapshots.png", "volume_change.png"})
    EXPECT_TRUE(is_png(dir.path / "figs" / png)) << png;
  // Figure 5's data: every locality converged at both thresholds, and the stricter threshold
  // never needs fewer steps.
  std::ifstream csv(dir.path / "figs" / "fig5_timing.csv");
  std::string line;
  std::getline(csv, line);
  int rows = 0;
  long previous_steps = 0;
  while (std::getline(csv, line)) {
    int n = 0, converged = 0;
    double threshold = 0, ms = 0;
    long steps = 0;
    ASSERT_EQ(
        std::sscanf(line.c_str(), "%d,%lf,%lf,%ld,%d", &n, &threshold, &ms, &steps, &converged), 5)
        << line;
    EXPECT_EQ(converged, 1) << line;
    if (threshold < 5e-4) EXPECT_GE(steps, previous_steps) << line;
    previous_steps = steps;
    ++rows;
  }
  EXPECT_EQ(rows, 6);
  for (const auto& e : fs::directory_iterator(dir.path / "figs"))
    EXPECT_EQ(e.path().extension() == ".tmp", false) << e.path();
}

TEST(Bench, QuickRunReportsEveryKeyForTwoModels) {
  test::TempDir dir;
  const auto r = run_shell(dir, quoted(test::lamina_cli()) + " bench --quick --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json j = json::parse(r.out);
  EXPECT_GT(j["memory_bandwidth_gb_s"].get<double>(), 0.1);
  ASSERT_EQ(j["models"].size(), 2u);
  EXPECT_LT(j["models"][0]["nodes"].get<int>(), j["models"][1]["nodes"].get<int>());
  for (const json& m : j["models"]) {
    for (const char* integrator : {"explicit", "implicit"}) {
      EXPECT_GT(m[integrator]["us_per_step"].get<double>(), 0.0);
      EXPECT_GT(m[integrator]["steps_per_second"].get<double>(), 0.0);
    }
    const double fraction = m["explicit"]["fraction_of_floor"].get<double>();
    EXPECT_GT(fraction, 0.0);
    EXPECT_LT(fraction, 1.5) << "faster than the memory system allows: the floor model is wrong";
    EXPECT_GT(m["build_seconds"].get<double>(), 0.0);
  }
  EXPECT_TRUE(j["models"][0]["poke_to_rest"]["converged"].get<bool>());
  // The physical liver at a haptic loop's step, coupled springs under the scene's tool and
  // Neo-Hookean under a haptic tip (what it measures, not how fast: a benchmark).
  ASSERT_EQ(j["physical"].size(), 2u);
  EXPECT_EQ(j["physical"][0]["name"], "physical_paper");
  EXPECT_EQ(j["physical"][1]["name"], "physical_paper_neo_hookean");
  for (const json& p : j["physical"]) {
    EXPECT_DOUBLE_EQ(p["dt_s"].get<double>(), 0.001);
    EXPECT_GT(p["tets"].get<int>(), 0);
    EXPECT_GT(p["us_per_step"].get<double>(), 0.0);
    EXPECT_GT(p["cg_iterations"].get<double>(), 0.0);
    EXPECT_FALSE(p["unstable"].get<bool>());
    // Honest accuracy: the real-time solve against the same poke solved to 1e-8, every step
    // of which converged, within 1% of the peak displacement (issue 48).
    EXPECT_GT(p["peak_displacement_mm"].get<double>(), 0.1) << p.dump();  // the tip dents 0.3 mm
    EXPECT_EQ(p["reference_unsolved_steps"].get<int>(), 0) << p.dump();
    EXPECT_GT(p["reference_cg_iterations"].get<double>(), p["cg_iterations"].get<double>());
    EXPECT_LE(p["error_pct_of_peak"].get<double>(), 1.0) << p.dump();
    EXPECT_GT(p["max_error_mm"].get<double>(), 0.0) << "two solves at different tolerances agree "
                                                       "exactly: the reference is not one";
  }
  EXPECT_FALSE(j.contains("clinical_build")) << "not in the quick run";
}

TEST(Figures, BadInputIsOneLineAndLeavesNoFolder) {
  test::TempDir dir;
  const auto r =
      run_shell(dir, quoted(test::lamina_cli()) + " figures --input nosuch.nii.gz -o figs");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("nosuch.nii.gz"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir.path / "figs"));
}

}  // namespace
}  // namespace lamina
