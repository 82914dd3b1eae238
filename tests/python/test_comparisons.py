"""Figure data of roadtex.comparisons: valleys and penetration (seed figure 4.3), von Meier at several
d* (figure 2.1), the edge effect (figure 3.1). The tests assert physics that could fail."""

from __future__ import annotations

import math

import numpy as np
import polars as pl
import pytest

import roadtex
from roadtex import comparisons as cmp
from roadtex.profiles.synthetic import self_affine_profile

DX = 5e-5
N = 4096


@pytest.fixture(scope="module")
def road() -> np.ndarray:
    return self_affine_profile(N, N * DX, rms_slope=0.2, seed=3)


def test_valleys_are_bounded_by_von_meier_contacts(road):
    """Each valley runs between two contact points of the von Meier envelope, the envelope clears
    the profile strictly inside, the depth is below the line joining the asperities, and the
    valleys do not overlap."""
    table = cmp.valleys(road, DX)
    assert table.height > 50
    e = roadtex.von_meier(road, DX, cmp.SEED_D_STAR)
    starts, ends = table["start"].to_numpy(), table["end"].to_numpy()
    assert np.all(ends[:-1] <= starts[1:])
    for a, b, depth in zip(starts, ends, table["depth"].to_numpy()):
        assert e[a] == road[a] and e[b] == road[b]
        assert np.all(e[a + 1:b] > road[a + 1:b])
        line = road[a] + (np.arange(a, b + 1) - a) / (b - a) * (road[b] - road[a])
        assert depth == pytest.approx(np.max(line - road[a:b + 1]), rel=1e-12)
        assert depth > 0
    assert np.allclose(table["width"].to_numpy(), (ends - starts) * DX)
    deep = cmp.valleys(road, DX, min_depth=2e-5)
    assert 0 < deep.height < table.height and deep["depth"].min() >= 2e-5


def test_penetration_limits():
    """A rubber on the profile itself fills every valley (ratio 1); one lying on the line through
    the asperities fills none (0); one held above them penetrates negatively."""
    z = np.array([0.0, -1.0, -2.0, -1.0, 0.5, -3.0, 0.2]) * 1e-4
    table = cmp.valleys(z, 1e-3, d_star=0.0)
    assert table.height == 2
    np.testing.assert_allclose(cmp.penetration(z, z, table), table["depth"].to_numpy())
    hull = roadtex.von_meier(z, 1e-3, 0.0)
    np.testing.assert_allclose(cmp.penetration(z, hull, table), 0.0, atol=1e-18)
    assert np.all(cmp.penetration(z, hull + 1e-5, table) == pytest.approx(-1e-5))


def test_penetration_grows_as_the_rubber_softens(road):
    """Seed figure 4.3: the INRETS rubber reaches deeper into the valleys as E falls, valley by
    valley; the von Meier penetration does not depend on E and is d* (w / 2)^2 at most."""
    moduli = [1e6, 2.5e6, 5e6, 1e7]
    frame = cmp.valley_penetration(road, DX, youngs_moduli=moduli)
    valleys = frame["valley"].n_unique()
    assert frame.height == valleys * len(moduli)
    wide = frame.pivot(on="youngs_modulus", index="valley", values="inrets_penetration").sort("valley")
    depth_of = frame.filter(pl.col("youngs_modulus") == 1e6).sort("valley")["depth"].to_numpy()
    by_modulus = wide.select([str(m) for m in moduli]).to_numpy()  # softest first
    slack = 1e-9 * depth_of.max()
    monotone = np.all(by_modulus[:, :-1] >= by_modulus[:, 1:] - slack, axis=1)
    assert monotone.mean() >= 0.95, f"only {monotone.mean():.2%} of valleys penetrate deeper as E falls"
    means = frame.group_by("youngs_modulus").agg(pl.col("inrets_ratio").mean()).sort("youngs_modulus")
    assert np.all(np.diff(means["inrets_ratio"].to_numpy()) < 0)
    assert means["inrets_ratio"][0] > 0.9  # 1 MPa fills nearly every valley
    vm = frame.group_by("valley").agg(pl.col("von_meier_penetration").n_unique().alias("k"),
                                      pl.col("von_meier_penetration").first(), pl.col("width").first(),
                                      pl.col("depth").first())
    assert (vm["k"] == 1).all()
    sag = cmp.SEED_D_STAR * (vm["width"].to_numpy() / 2) ** 2
    pen = vm["von_meier_penetration"].to_numpy()
    assert np.all(pen <= sag * (1 + 1e-9)) and np.all(pen <= vm["depth"].to_numpy() * (1 + 1e-12))
    ratios = frame.select("inrets_ratio", "von_meier_ratio").to_numpy()
    assert np.all((ratios >= 0) & (ratios <= 1))


def test_von_meier_envelope_lowers_as_d_star_rises(road):
    """Seed figure 2.1: at every point the envelope at a larger d* is no higher, and the mean depth
    above the road falls strictly; every envelope stays on or above the road."""
    d_stars = [10.0, 54.0, 200.0, 1000.0]
    frame = cmp.von_meier_envelopes(road, DX, d_stars=d_stars)
    assert frame.height == N * len(d_stars)
    envelopes = np.stack([frame.filter(pl.col("d_star") == d)["envelope"].to_numpy() for d in d_stars])
    assert np.all(envelopes[:-1] >= envelopes[1:] - 1e-15)
    depths = frame.group_by("d_star").agg(pl.col("depth").mean()).sort("d_star")["depth"].to_numpy()
    assert np.all(np.diff(depths) < 0)
    assert frame["depth"].min() >= 0.0
    np.testing.assert_array_equal(frame.filter(pl.col("d_star") == 54.0)["height"].to_numpy(), road)


def test_edge_effect_on_a_flat_profile():
    """Seed figure 3.1: the periodic pressure is uniform; the finite pressure rises at both ends
    (above 9 P) and sags to 2 P / pi in the middle, as the exact flat punch does."""
    frame = cmp.edge_effect(points=1024, length=0.1)
    periodic = frame.filter(pl.col("model") == "periodic")["pressure_ratio"].to_numpy()
    finite = frame.filter(pl.col("model") == "finite")["pressure_ratio"].to_numpy()
    exact = frame.filter(pl.col("model") == "flat punch (exact)")["pressure_ratio"].to_numpy()
    np.testing.assert_allclose(periodic, 1.0, rtol=1e-12)
    assert finite[0] > 9 and finite[-1] > 9
    assert finite[511] == pytest.approx(2 / math.pi, rel=2e-3)
    assert np.all(np.diff(finite[:512]) < 0) and np.all(np.diff(finite[512:]) > 0)
    middle = slice(100, 924)
    assert np.abs(finite[middle] - exact[middle]).max() < 2e-3
    assert finite.mean() == pytest.approx(1.0, rel=1e-12)
