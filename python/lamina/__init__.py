"""Lamina: real-time multi-layer mass-spring soft tissue for surgical simulation.

Units everywhere: millimetres, kilograms, seconds; forces in mN, stiffness in N/m, E in kPa.
Arrays are numpy views of the library's own memory (docs/python.md).

    import lamina
    model = lamina.build_model("phantom")                      # or a NIfTI/NRRD/MHA/DICOM path
    sim = lamina.Simulation(model, fixed=lamina.nodes_near_plane(model, (0, 40, 0), (0, 1, 0), 10))
    sim.add_tool(vertex=0, force_mn=(0, 300, 0), end_s=1.0)
    print(sim.run())                                           # steps until the organ rests
"""
import glob
import json
import os
import shutil
import subprocess
import sys

_HERE = os.path.dirname(os.path.abspath(__file__))


def _cannot_import(what, cause, remedy):
    """One ImportError that names this interpreter, where lamina was found, what is missing and
    what to do: pybind11's own is a bare 'initialization failed'."""
    return ImportError("lamina cannot be imported: %s (%s). Interpreter: %s (Python %d.%d); "
                       "lamina found at %s. %s" % (what, cause, sys.executable,
                                                   sys.version_info[0], sys.version_info[1],
                                                   _HERE, remedy))


try:  # the compiled module hands out numpy arrays: without numpy it cannot initialise
    import numpy  # noqa: F401
except ImportError as _e:
    raise _cannot_import(
        "numpy is missing", _e,
        "Install numpy for this interpreter (apt-get install python3-numpy for Debian's "
        "/usr/bin/python3, or this interpreter's `-m pip install numpy`), or run the Python "
        "lamina was built with.") from None

# OpenMP threads spin at a barrier for GOMP_SPINCOUNT iterations (libgomp's default 300,000)
# before they sleep: two lamina processes on a 2-core machine, or lamina beside anything else,
# then spin on the cores the other needs (lamina.run_scene took 53 s instead of 7 s on a loaded
# machine). The command-line tool bounds it to 3,000 for the same reason (apps/lamina/main.cpp).
# libgomp reads the variable when it loads, which is the import below; a user's own setting is
# left alone.
if "GOMP_SPINCOUNT" not in os.environ and "OMP_WAIT_POLICY" not in os.environ:
    os.environ["GOMP_SPINCOUNT"] = "3000"

try:
    from ._lamina import (EmbeddedSurface, Error, Mask, Model, Simulation, StepStats, World,
                          __version__, build_model, load_model, nodes_near_plane, phantom,
                          read_mask, resect, scene_simulation, world_scene)
except ImportError as _e:
    _built = sorted(os.path.basename(p) for p in glob.glob(os.path.join(_HERE, "_lamina*.so")))
    raise _cannot_import(
        "its compiled module did not load", _e,
        "Compiled modules here: %s; a module built for another Python version (its file name "
        "says which) or a library it links that this system lacks gives this. Rebuild lamina "
        "with this interpreter (cmake -DPython3_EXECUTABLE=%s) or run the one it was built "
        "with." % (", ".join(_built) or "none", sys.executable)) from _e

__all__ = ["EmbeddedSurface", "Error", "Mask", "Model", "Simulation", "StepStats", "World", "__version__",
           "build_model", "load_model", "nodes_near_plane", "phantom", "read_mask", "resect",
           "scene_simulation", "world_scene", "run_scene", "validate", "executable"]


def run_scene(scene="phantom", *, paper=False, until_s=float("inf")):
    """Runs a scene (a path, 'phantom', or a dict of a scene file's keys) in this process as
    `lamina run` does, without its files: the same model, setup, steps and rest test. Returns
    Simulation.run()'s dict with the scene's name and the total step count."""
    sim = scene_simulation(scene, paper=paper)
    result = sim.run(until_s=until_s)
    result["scene"] = sim.scene
    return result


def executable():
    """The `lamina` command-line tool beside this module: $LAMINA_EXECUTABLE, the install's
    bin/lamina, the build tree's, or the first on PATH."""
    here = _HERE
    candidates = [os.environ.get("LAMINA_EXECUTABLE", "")]
    # installed: PREFIX/lib/pythonX.Y/dist-packages/lamina -> PREFIX/bin/lamina
    candidates.append(os.path.join(here, "..", "..", "..", "..", "bin", "lamina"))
    # build tree: BUILD/python/lamina -> BUILD/lamina
    candidates.append(os.path.join(here, "..", "..", "lamina"))
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return os.path.abspath(c)
    found = shutil.which("lamina")
    if found:
        return found
    raise Error("lamina: the command-line tool was not found; set LAMINA_EXECUTABLE")


def validate(scene="phantom", *, quick=False, depths=None, deepest=False, stability=False,
             refine=None, output=None, timeout_s=None):
    """`lamina validate` (the mass-spring model against finite elements, or the stability suite)
    and its JSON summary as a dict. It runs the command-line tool: minutes of work, for which a
    process start costs nothing. `refine=[1284, 5000, 20000]`: the dent at those skin sizes
    (`--refine`). Raises lamina.Error with the tool's one-line message."""
    cmd = [executable(), "validate", str(scene), "--json"]
    if quick:
        cmd.append("--quick")
    if depths:
        cmd += ["--depths", ",".join(str(d) for d in depths)]
    if deepest:
        cmd.append("--deepest")
    if stability:
        cmd.append("--stability")
    if refine:
        cmd += ["--refine", ",".join(str(int(n)) for n in refine)]
    if output:
        cmd += ["-o", str(output)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s)
    if done.returncode != 0:
        lines = [l for l in done.stderr.splitlines() if l.startswith("error")] or \
            done.stderr.strip().splitlines()[-1:] or ["exit code %d" % done.returncode]
        err = Error(lines[-1])
        err.exit_code = done.returncode
        raise err
    return json.loads(done.stdout)
