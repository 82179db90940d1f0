import os
import pathlib

import pytest

import lamina

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def phantom_model():
    """The built-in phantom with the default options (0.4 s to build; shared, read-only)."""
    return lamina.build_model("phantom")


@pytest.fixture(scope="session")
def cli():
    return lamina.executable()


def front_node(model):
    """The most anterior skin node (smallest y), where the paper pokes."""
    return int(model.X[: model.skin_node_count, 1].argmin())


def back_nodes(model):
    """Nodes within 10 mm of the posterior-most plane: the paper's fixed region."""
    back = model.X[model.X[:, 1].argmax()]
    return lamina.nodes_near_plane(model, back, (0, 1, 0), 10.0)
