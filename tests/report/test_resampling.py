"""The report's numpy resampling against scipy.ndimage, which it replaces so a cold report need not import scipy:
fig. 16's contour smoothing (``gaussian_filter``, mode nearest), the terrain's resize to square cells (``zoom``,
order 1) and the overlays' bilinear sampling (``map_coordinates``, order 1, constant outside)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter, map_coordinates, zoom

from vinecli.report.fieldmap.overlay import _sample, resize_bilinear
from vinecli.report.path_plots import gaussian_smooth


@pytest.mark.parametrize(("shape", "sigma"), [((129, 97), 3.2), ((20, 40), 1.0), ((5, 7), 2.5)])
def test_gaussian_smooth_is_scipys_gaussian_filter(shape: tuple[int, int], sigma: float) -> None:
    z = np.random.default_rng(1).normal(size=shape).cumsum(axis=0)
    assert np.allclose(gaussian_smooth(z, sigma), gaussian_filter(z, sigma=sigma, mode="nearest"), atol=1e-12)


def test_gaussian_smooth_spreads_no_data_no_further_than_its_kernel() -> None:
    z = np.zeros((60, 60))
    z[30, 30] = np.nan
    s = gaussian_smooth(z, 2.0)  # kernel radius 8 cells
    assert np.isnan(s[30, 38]) and np.isfinite(s[30, 39]) and np.isfinite(s[0, 0])


@pytest.mark.parametrize(("shape", "factor"), [((200, 130), (1.0013, 0.9987)), ((50, 60), (1.3, 0.7)),
                                               ((3, 4), (2.0, 1.5))])
def test_resize_bilinear_is_scipys_zoom(shape: tuple[int, int], factor: tuple[float, float]) -> None:
    z = np.random.default_rng(2).normal(size=shape).cumsum(axis=1)
    want = zoom(z, factor, order=1)
    assert np.allclose(resize_bilinear(z, want.shape), want, atol=1e-12)


def test_bilinear_sample_is_map_coordinates_inside_and_fill_outside() -> None:
    rng = np.random.default_rng(3)
    a = rng.uniform(0, 255, size=(30, 50, 4))
    ci, cj = rng.uniform(-3, 33, size=(40, 40)), rng.uniform(-3, 53, size=(40, 40))
    got = _sample(a, ci, cj, smooth=True, fill=0.0)
    for c in range(4):
        want = map_coordinates(a[..., c], [ci, cj], order=1, mode="constant", cval=0.0)
        assert np.allclose(got[..., c], want, atol=1e-9)
    nearest = _sample(a[..., 0], ci, cj, smooth=False, fill=-1.0)
    ri, rj = np.rint(ci).astype(int), np.rint(cj).astype(int)
    inside = (ri >= 0) & (ri < 30) & (rj >= 0) & (rj < 50)
    assert (~inside).any() and np.all(nearest[~inside] == -1.0)
    assert np.array_equal(nearest[inside], a[ri[inside], rj[inside], 0])
