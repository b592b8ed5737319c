"""Coordinate conversions between the source, the exemplar and the output-scale grid."""
import numpy as np
import pytest

from proxyshade.synthesis.exemplar import grid_to_source, levels_for, source_to_grid


@pytest.mark.parametrize("step", [1.0, 2.0, 0.75, 4.0, 3.3])
def test_grid_centres_and_their_nearest_inverse(step):
    i = np.arange(-3, 40)
    s = grid_to_source(i, step)
    assert s.dtype == np.float32
    np.testing.assert_allclose(s, (i + 0.5) * step - 0.5, rtol=0, atol=1e-5)  # pixel centres line up
    np.testing.assert_array_equal(source_to_grid(s, step), i)  # a centre maps back to its pixel
    # any source coordinate goes to the grid pixel whose centre is nearest
    x = np.random.default_rng(0).uniform(-2, 60, 500)
    centres = grid_to_source(np.arange(-10, 120), step).astype(np.float64)
    nearest = np.arange(-10, 120)[np.abs(x[:, None] - centres[None]).argmin(1)]
    got = source_to_grid(x, step)
    far_from_tie = np.abs(np.abs(x - grid_to_source(got, step)) - step / 2) > 1e-4
    np.testing.assert_array_equal(got[far_from_tie], nearest[far_from_tie])


def test_levels_for():
    assert levels_for(32, 32) == 1 and levels_for(16, 32) == 1
    assert levels_for(256, 32) == 4 and levels_for(64, 32) == 2
