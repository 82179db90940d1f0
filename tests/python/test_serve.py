"""Serving from Python (Simulation.serve, World.serve: the library's network edge, as `lamina
serve`): 3D Slicer's OpenIGTLink streams the deformed skin to a client, the web page is served
from the build beside the library, and bad options are refused by name before anything listens."""
import socket
import threading
import time

import pytest

import lamina
from conftest import fetch_page, free_port, polydata_points, serve_in_thread


def test_serve_streams_the_skin_over_openigtlink():
    sim = lamina.scene_simulation("phantom")
    port = free_port()
    thread, out = serve_in_thread(sim, port=port, duration_s=4.0, rate_hz=500.0)
    points = polydata_points(port, {"LaminaSkin", "display_skin"})
    thread.join(60)
    assert not thread.is_alive()
    assert out.get("code") == 0, out
    # The simulation's skin, and the display skin the model carries, each streamed.
    assert points.get("LaminaSkin") == sim.model.skin_node_count, points
    assert points.get("display_skin", 0) > sim.model.skin_node_count, points
    # The simulation served was a copy: this one has not stepped.
    assert sim.time_s == 0.0


def test_serve_gives_the_page_from_the_library_build():
    sim = lamina.scene_simulation("phantom")
    port, web_port = free_port(), free_port()
    thread, out = serve_in_thread(sim, port=port, web=True, web_port=web_port, web_token="t0k3n",
                                  duration_s=3.0)
    page = fetch_page(web_port, "t0k3n", thread)
    thread.join(60)
    assert out.get("code") == 0, out
    assert page is not None and "<html" in page.lower()


def test_serve_refuses_bad_options_by_name():
    sim = lamina.scene_simulation("phantom")
    with pytest.raises(lamina.Error, match="serve: colour.*not an option"):
        sim.serve(colour="red")
    with pytest.raises(lamina.Error, match="--send-hz"):
        sim.serve(send_hz=-1.0)
    with pytest.raises(lamina.Error, match="serve: port.*cannot take"):
        sim.serve(port="eighteen")
    # A port in use is refused before anything is served.
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        with pytest.raises(lamina.Error, match="port"):
            sim.serve(port=busy.getsockname()[1], duration_s=1.0)


def test_serve_ends_on_ctrl_c_with_keyboard_interrupt():
    # No duration: the serve runs until Ctrl-C, which Python raises once the serve has stopped.
    import os
    import signal
    sim = lamina.scene_simulation("phantom")
    timer = threading.Timer(1.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    started = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        sim.serve(port=free_port())
    timer.join()
    assert time.monotonic() - started < 30.0
