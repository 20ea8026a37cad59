"""Fixtures of the motion tests."""

import pytest
from .motion_jobs import random_polyline_moves, zigzag_moves


@pytest.fixture
def zigzag():
    return zigzag_moves()


@pytest.fixture(params=range(4))
def random_job(request):
    return random_polyline_moves(request.param)
