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
    deepest = np.rint(table["x_deepest"].to_numpy() / DX).astype(int)
    for a, b, k, depth in zip(starts, ends, deepest, table["depth"].to_numpy()):
        assert e[a] == road[a] and e[b] == road[b]
        assert np.all(e[a + 1:b] > road[a + 1:b])
        # The chord between the asperities lies between their heights, so the depth below it is
        # bracketed by the valley floor's drop below the lower and the higher asperity.
        floor = road[a:b + 1].min()
        assert min(road[a], road[b]) - floor <= depth * (1 + 1e-12)
        assert depth <= (max(road[a], road[b]) - floor) * (1 + 1e-12)
        assert a < k < b and depth > 0
    assert np.allclose(table["width"].to_numpy(), table["x_end"].to_numpy() - table["x_start"].to_numpy())
    deep = cmp.valleys(road, DX, min_depth=2e-5)
    assert 0 < deep.height < table.height and deep["depth"].min() >= 2e-5


def test_valley_depths_widths_and_bottoms_of_v_valleys_are_exact():
    """A row of V-shaped valleys between sharp peaks at height 0, each steep enough that the
    envelope's parabola over it (sag d* (w / 2)^2, slope d* w at the ends) clears its flanks, i.e.
    deeper than 2 d* (w / 2)^2, so that the envelope rests on the peaks: the valleys are the Vs, their width the
    distance between peaks, their deepest point the V's bottom and their depth the V's, exactly. The
    same row on a 3 % grade gives the same table: a straight line added to the profile changes
    neither the envelope's curvature nor the depth below the chord."""
    dx = 1e-4
    halves = [15, 20, 25, 10, 20]                      # flank lengths (samples)
    depths = [0.5e-3, 1.0e-3, 2.0e-3, 1.5e-3, 0.8e-3]  # m
    z = [0.0]
    for half, depth in zip(halves, depths):
        assert depth > 2 * cmp.SEED_D_STAR * (half * dx) ** 2
        j = np.arange(1, 2 * half + 1)
        z.extend(-depth * (1 - np.abs(j - half) / half))
    z = np.array(z)
    peaks = np.concatenate([[0], np.cumsum(2 * np.array(halves))])
    for grade in (0.0, 0.03):
        table = cmp.valleys(z + grade * dx * np.arange(z.size), dx)
        assert table["start"].to_list() == peaks[:-1].tolist() and table["end"].to_list() == peaks[1:].tolist()
        np.testing.assert_allclose(table["width"], 2 * np.array(halves) * dx, rtol=1e-12)
        np.testing.assert_allclose(table["x_deepest"], (peaks[:-1] + np.array(halves)) * dx, rtol=1e-12)
        np.testing.assert_allclose(table["depth"], depths, rtol=1e-9)
    assert cmp.valleys(z, dx, min_depth=1.2e-3)["depth"].to_list() == pytest.approx([2.0e-3, 1.5e-3], rel=1e-9)


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
