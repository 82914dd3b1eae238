"""Issue 14's conditioning: reference plates only as long flat stretches at the ends, spikes by a
criterion that means the same at any sampling, what is removed counted and warned about; readers'
options (decimal commas) and errors naming the file; implausible heights warned about everywhere."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import roadtex
from roadtex.errors import ConditioningWarning, ImplausibleTextureWarning, ProfileFormatError
from roadtex.profiles import Profile
from roadtex.profiles.conditioning import WARN_SPIKE_FRACTION, clean, spike_mask
from roadtex.profiles.trend import remove_lines


def road(dx: float, length: float = 1.0, seed: int = 0) -> Profile:
    return roadtex.synthetic_pavement("dense_asphalt", length, dx, seed=seed)


def with_plates(profile: Profile, plate: float = 0.04, height: float = 0.045) -> Profile:
    z = profile.heights.copy()
    n = int(plate / profile.dx)
    rng = np.random.default_rng(0)
    for part in (slice(100, 100 + n), slice(z.size - 100 - n, z.size - 100)):
        top = np.full(part.stop - part.start, np.nan)
        seen = rng.random(top.size) < 0.1          # the laser loses most of the plate's top
        top[seen] = height + 5e-4 * rng.standard_normal(seen.sum())
        z[part] = top
    return Profile(z, profile.positions, profile.dx)


@pytest.mark.parametrize("dx", [0.05e-3, 0.5e-3])
def test_a_single_high_reading_is_a_spike_never_a_plate(dx: float) -> None:
    p = road(dx, 1.8)
    z = p.heights.copy()
    at = int(0.75 / dx)
    z[at] += 0.03
    cleaned, summary = clean(Profile(z, p.positions, p.dx))
    assert summary.trimmed_length == 0.0 and summary.plates == "none"
    assert np.isnan(cleaned.heights[at]) and len(cleaned) == len(p)


def test_plates_at_both_ends_are_trimmed_and_counted() -> None:
    p = with_plates(road(0.0375e-3, 1.0))
    cleaned, summary = clean(p)
    assert "start" in summary.plates and "end" in summary.plates
    assert np.nanmax(cleaned.heights) < 0.01
    # everything outside the plates goes with them: 100 samples + 40 mm each side, plus the margins
    assert summary.trimmed_length == pytest.approx(2 * (100 * p.dx + 0.04 + 0.002), abs=2 * p.dx + 1e-6)


def test_a_plate_in_the_middle_of_the_run_is_not_a_plate() -> None:
    p = road(0.1e-3, 2.0)
    z = p.heights.copy()
    z[9000:9400] = 0.045        # 40 mm of something flat and high at 0.9 m
    _, summary = clean(Profile(z, p.positions, p.dx))
    assert summary.trimmed_length == 0.0


@pytest.mark.parametrize("dx", [0.0375e-3, 0.1e-3, 0.5e-3])
def test_spike_criterion_keeps_steep_real_edges_at_any_sampling(dx: float) -> None:
    # a square wave of 3 mm steps every 5 mm: the steepest real texture, a step, must survive
    x = np.arange(int(0.2 / dx)) * dx
    z = 1.5e-3 * np.sign(np.sin(2 * np.pi * x / 10e-3))
    flagged = spike_mask(Profile.from_heights(z, dx), 3.0)
    assert not flagged.any()
    # ... while a 2 mm spike one reading wide is found wherever it is
    z2 = z.copy()
    z2[len(z) // 3 + 7] += 2e-3
    assert spike_mask(Profile.from_heights(z2, dx), 3.0).sum() == 1


def test_spike_threshold_matches_iso_on_its_half_millimetre_grid() -> None:
    # on the 0.5 mm grid, an isolated spike is flagged by ISO 13473-1 when it jumps >= alpha x 0.5 mm
    dx, alpha = 0.5e-3, 3.0
    base = np.zeros(400)
    for height, expected in ((1.4e-3, False), (1.6e-3, True)):
        z = base.copy()
        z[200] = height
        p = Profile.from_heights(z, dx)
        assert bool(spike_mask(p, alpha)[200]) is expected
        assert bool(np.isnan(p.remove_spikes(alpha).heights[200])) is expected


def test_deep_dropout_codes_are_removed_whatever_their_width() -> None:
    p = road(0.05e-3, 1.0)
    z = p.heights.copy()
    z[5000:5400] = -0.85     # 20 mm of a "no reading" code
    cleaned, summary = clean(Profile(z, p.positions, p.dx))
    assert np.isnan(cleaned.heights[5000:5400]).all()
    assert summary.outlier_fraction == pytest.approx(400 / z.size)


def test_removals_beyond_the_threshold_are_warned_about_and_recorded() -> None:
    p = road(0.5e-3, 1.0)
    z = p.heights.copy()
    z[::10] += 5e-3                      # 10 % of the readings are spikes
    with pytest.warns(ConditioningWarning, match="spikes"):
        _, summary = clean(Profile(z, p.positions, p.dx))
    assert summary.spike_fraction + summary.outlier_fraction > WARN_SPIKE_FRACTION
    assert summary.warnings and "spikes" in summary.warnings[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, quiet = clean(Profile(z, p.positions, p.dx), warn=False)
    assert quiet.warnings == summary.warnings


def test_decimal_commas_are_read_and_errors_name_the_file(tmp_path) -> None:
    path = tmp_path / "export.csv"
    path.write_text("Distance (mm);Height (mm)\n0,000;-3,015\n0,500;-2,500\n1,000;1,250\n", encoding="utf-8")
    p = roadtex.read_profile(path)
    np.testing.assert_allclose(p.heights, [-3.015e-3, -2.5e-3, 1.25e-3])
    headerless = tmp_path / "nohead.tsv"
    headerless.write_text("0\t1.0\n1\t2.0\n", encoding="utf-8")
    with pytest.raises(ProfileFormatError, match=r"^nohead\.tsv: .*height_unit"):
        roadtex.read_profile(headerless)


def test_every_function_taking_heights_warns_on_millimetres() -> None:
    z_mm = road(0.5e-3, 0.5).heights * 1e3
    calls = {
        "contact": lambda: roadtex.contact(z_mm, 0.5e-3, youngs_modulus=2.5e6, mean_pressure=2e5,
                                           raise_on_nonconvergence=False),
        "von_meier": lambda: roadtex.von_meier(z_mm, 0.5e-3),
        "third_octave_levels": lambda: roadtex.third_octave_levels(z_mm, 0.5e-3),
        "clapp": lambda: roadtex.clapp(z_mm[:512], 0.5e-3, 2.5e6, 2e5, sub_profile=256, overlap=64),
        "from_heights": lambda: Profile.from_heights(z_mm, 0.5e-3),
    }
    for name, call in calls.items():
        with pytest.warns(ImplausibleTextureWarning):
            try:
                call()
            except roadtex.errors.RoadtexError:
                pass  # the warning is what is checked; solving mm as m may fail too
        assert name


def test_line_fits_are_the_same_bits_for_a_block_and_for_each_row() -> None:
    rows = np.random.default_rng(3).standard_normal((64, 13_334))
    block, _ = remove_lines(rows)
    for i in (0, 17, 63):
        single, _ = remove_lines(rows[i])
        assert np.array_equal(block[i], single)


def test_mpd_takes_dropout_codes_as_dropouts_not_as_texture() -> None:
    """A run of -850 mm codes is the device's "no reading": ISO 13473-1's spike test flags only its
    edges, so MPD would take the code as a 850 mm deep valley."""
    p = road(0.05e-3, 1.0, seed=3)
    clean_mpd = roadtex.mpd(p)
    z = p.heights.copy()
    z[5000:5060] = -0.85     # 3 mm of codes, within one 100 mm baseline
    coded = roadtex.mpd(Profile(z, p.positions, p.dx))
    assert coded.mpd == pytest.approx(clean_mpd.mpd, rel=0.02), (coded.mpd, clean_mpd.mpd)
    assert coded.is_valid and coded.valid_segments == clean_mpd.valid_segments
    assert coded.segments["dropout_fraction"].max() == pytest.approx(60 / 2000)
    assert any("drop-out codes" in step for step in coded.profile.history)


def test_dropout_codes_do_not_make_a_file_look_like_the_wrong_unit() -> None:
    """Heights in metres with a few -9999 codes: the unit is right, nothing to warn about."""
    p = road(0.5e-3, 1.0)
    z = p.heights.copy()
    z[[100, 700, 1300, 1900]] = -9.999
    from roadtex.profiles.plausibility import implausible_texture
    assert implausible_texture(z, p.dx, "coded.csv", measured=True) is None
    assert implausible_texture(z * 1e3, p.dx, "mm.csv", measured=True) is not None  # mm read as m


def test_plane_fit_agrees_with_lapack_and_refuses_a_line() -> None:
    """The plain-sum plane (thread-count independent) against LAPACK's least squares on scattered
    points; one row along x has no slope across; points on a diagonal span no plane."""
    from roadtex.errors import InvalidInputError
    from roadtex.profiles.trend import plane_fit

    rng = np.random.default_rng(5)
    x, y = rng.uniform(0, 0.2, 500), rng.uniform(0, 0.05, 500)
    z = 1e-3 + 0.01 * x - 0.03 * y + 1e-4 * rng.standard_normal(500)
    a, b, c, xm, ym = plane_fit(x, y, z)
    design = np.column_stack([np.ones_like(x), x - x.mean(), y - y.mean()])
    expected, *_ = np.linalg.lstsq(design, z, rcond=None)
    np.testing.assert_allclose([a, b, c], expected, rtol=1e-10, atol=1e-15)
    assert (xm, ym) == (x.mean(), y.mean())
    a1, b1, c1, _, _ = plane_fit(x, np.full_like(x, 0.01), z)
    assert c1 == 0.0 and b1 == pytest.approx(np.polyfit(x, z, 1)[0], rel=1e-10)
    with pytest.raises(InvalidInputError, match="along and across"):
        plane_fit(x, 2 * x, z)
