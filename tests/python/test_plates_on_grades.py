"""Reference plates on real roads, which are seldom level (review finding H2): a grade or a vertical
curve is never cut as a plate, a plate on a graded road is still found where it is, and the three
CAPTIF files are trimmed exactly as before the detector measured heights against the road next to
the plate instead of the run's median."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import roadtex
from roadtex.errors import ConditioningWarning
from roadtex.profiles import Profile, mpd, read_profile
from roadtex.profiles.conditioning import PLATE_END_ZONE, clean, find_reference_plates, road_line

DX = 0.5e-3
PLATE = 0.04            # a CAPTIF plate: about 40 mm long, 47 mm above the road, mostly drop-outs
PLATE_HEIGHT = 0.047
OUTSIDE = 0.02          # road outside the plate, between it and the run's end
MARGIN = 0.002

#: The reviewer's cases: run length (m) and grade, each both rising and falling.
GRADES = [(20.0, 0.0025), (10.0, 0.005), (5.0, 0.01), (2.0, 0.025)]


def road(length: float, seed: int = 1, dx: float = DX) -> Profile:
    return roadtex.synthetic_pavement("dense_asphalt", length, dx, seed=seed)


def with_shape(profile: Profile, shape: np.ndarray) -> Profile:
    return Profile(profile.heights + shape, profile.positions, profile.dx)


def assert_kept_whole(profile: Profile) -> None:
    """Nothing trimmed by the bulk job's cleaning, by trim_reference_plates or by the detector, and
    no warning about trimming."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        cleaned, summary = clean(profile)
    assert summary.plates == "none" and summary.trimmed_length == 0.0
    assert len(cleaned) == len(profile)
    assert not [w for w in caught if issubclass(w.category, ConditioningWarning) and "trimmed" in str(w.message)]
    assert find_reference_plates(profile) == (profile.positions[0], profile.positions[-1], [])
    assert "none found" in profile.trim_reference_plates().history[-1]


@pytest.mark.parametrize("sign", [1, -1], ids=["rising", "falling"])
@pytest.mark.parametrize(("length", "grade"), GRADES, ids=[f"{n:g}m-{100 * g:g}%" for n, g in GRADES])
def test_an_ordinary_grade_is_never_a_plate(length: float, grade: float, sign: int) -> None:
    # before: 20 m at 0.25 % lost 1.97 m (rising) from the end labelled a plate, 2 m at 2.5 % 0.2 m
    p = road(length)
    graded = with_shape(p, sign * grade * p.positions)
    assert np.ptp(graded.heights) > 0.02 + np.ptp(p.heights)    # the grade lifts one end past 20 mm
    assert_kept_whole(graded)


@pytest.mark.parametrize("sign", [1, -1], ids=["rising", "falling"])
def test_mpd_keeps_every_baseline_of_a_graded_road(sign: int) -> None:
    # before: 5 of the 50 baselines of 5 m at 1 % were cut away with the "plate"
    p = road(5.0)
    result = mpd(with_shape(p, sign * 0.01 * p.positions))
    assert len(result.segments) == 50
    assert result.segments["start"][0] == pytest.approx(0.0, abs=DX)
    assert result.segments["end"][-1] == pytest.approx(5.0, abs=DX)


@pytest.mark.parametrize("curve", ["crest ending at its top", "sag starting at its bottom",
                                   "crest, +1 % to -1 %", "sag, -1 % to +1 %"])
def test_a_vertical_curve_is_never_a_plate(curve: str) -> None:
    p = road(20.0, seed=2)
    x = p.positions
    # before: the first two lost 4.05 m and 2.51 m from the end, labelled a plate
    if curve == "crest ending at its top":      # climbing at 1 %, easing to level at the end
        shape = -0.01 / (2 * 20.0) * (20.0 - x) ** 2
    elif curve == "sag starting at its bottom":  # level at the start, climbing at 0.4 % at the end
        shape = 0.004 / (2 * 20.0) * x**2
    else:
        shape = (-1 if curve.startswith("crest") else 1) * 0.02 / (2 * 20.0) * (x - 10.0) ** 2
    assert_kept_whole(with_shape(p, shape))


def plated(length: float, grade: float, dx: float = DX) -> tuple[Profile, float, float]:
    """A graded road with a CAPTIF-like plate near each end: OUTSIDE (m) of road, a PLATE (m) long
    level plate PLATE_HEIGHT above the road there with 8 in 9 of its readings lost, then the road.
    Returns the profile and the positions of the first and last road readings inside the plates."""
    p = road(length, seed=3, dx=dx)
    x = p.positions
    z = p.heights + grade * x
    rng = np.random.default_rng(4)
    n_out, n_plate = int(round(OUTSIDE / dx)), int(round(PLATE / dx))
    for part in (slice(n_out, n_out + n_plate), slice(x.size - n_out - n_plate, x.size - n_out)):
        top = np.full(n_plate, np.nan)
        seen = np.arange(n_plate) % 9 == 4          # 9 readings of 80 on a 0.5 mm grid
        top[seen] = grade * x[part].mean() + PLATE_HEIGHT + 2e-4 * rng.standard_normal(int(seen.sum()))
        z[part] = top
    return Profile(z, x, dx), float(x[n_out + n_plate]), float(x[x.size - n_out - n_plate - 1])


@pytest.mark.parametrize("grade", [0.0, 0.01, -0.01, 0.025, -0.025])
@pytest.mark.parametrize("length", [5.0, 2.0, 0.4])
def test_a_plate_on_a_graded_road_is_found_where_it_is(length: float, grade: float) -> None:
    p, first_road, last_road = plated(length, grade)
    trimmed = p.trim_reference_plates(margin=MARGIN)
    assert trimmed.positions[0] == pytest.approx(first_road + MARGIN, abs=DX)
    assert trimmed.positions[-1] == pytest.approx(last_road - MARGIN, abs=DX)
    step = trimmed.history[-1]
    assert f"plates at start ({OUTSIDE:g}.." in step and f"end ({length - OUTSIDE - PLATE:g}.." in step
    _, summary = clean(p, warn=False)      # 0.4 m: more than a quarter trimmed, warned
    assert summary.trimmed_length == pytest.approx(2 * (OUTSIDE + PLATE + MARGIN), abs=3 * DX)


def test_a_high_flat_stretch_reaching_beyond_the_end_zone_is_not_a_plate() -> None:
    # before: anything starting within 0.25 m of an end and ending before the middle was a plate
    p = road(2.0, dx=0.1e-3)
    z = p.heights.copy()
    inside = (p.positions >= PLATE_END_ZONE - 0.05) & (p.positions < PLATE_END_ZONE + 0.05)
    z[inside] = 0.045
    _, summary = clean(Profile(z, p.positions, p.dx), warn=False)
    assert summary.plates == "none" and summary.trimmed_length == 0.0
    # not dropped silently either: its readings are counted as gross outliers
    assert summary.outlier_fraction == pytest.approx(inside.mean(), abs=1e-3)


def test_the_road_line_follows_the_road_and_not_the_plate() -> None:
    texture = road(0.5, dx=1e-4).heights
    x = 0.25 + 1e-4 * np.arange(texture.size)
    z = 0.03 * x + 0.004 + texture
    slope, offset = road_line(x, z)
    fitted = np.polyfit(x, z, 1)        # least squares, numpy's
    assert slope == pytest.approx(fitted[0], abs=2e-3) and offset == pytest.approx(fitted[1], abs=1e-3)
    # 30 % of the outer third 47 mm high and 10 % of all readings lost: the line moves by a small
    # part of the 20 mm a plate must stand above it (least squares moves by 17 mm at x = 0.25)
    z_bad = z.copy()
    z_bad[:500] += 0.047
    z_bad[::10] = np.nan
    bad_slope, bad_offset = road_line(x, z_bad)
    assert abs(bad_slope * x + bad_offset - (slope * x + offset)).max() < 3e-3
    valid = ~np.isnan(z_bad)
    assert abs(np.polyval(np.polyfit(x[valid], z_bad[valid], 1), x[0]) - (slope * x[0] + offset)) > 5e-3
    assert road_line(x[:2], z[:2]) == (0.0, float(np.median(z[:2])))
    assert road_line(x, np.full(x.size, np.nan)) == (0.0, 0.0)


#: What the three CAPTIF files were trimmed to before the detector changed (found by the median
#: rule, margin 2 mm): plates as written in the history line, first and last positions kept (m).
CAPTIF_BEFORE = {
    "20211011_aylesbury_dec_station_0.dat": ("start (0.019082..0.060282 m) and end (1.87239..1.91213 m)",
                                             0.062344, 1.870326, 48228),
    "20211011_aylesbury_dec_station_1.dat": ("start (0.027329..0.068342 m) and end (1.88071..1.92045 m)",
                                             0.070404, 1.878649, 48235),
    "20211011_aylesbury_dec_station_10.dat": ("start (0.018745..0.05987 m) and end (1.8725..1.91239 m)",
                                              0.061932, 1.870439, 48242),
}


def test_captif_plates_are_trimmed_exactly_as_before(captif_file: Path) -> None:
    plates, first, last, n = CAPTIF_BEFORE[captif_file.name]
    p = read_profile(captif_file)
    cleaned, summary = clean(p)
    assert summary.plates == plates
    assert (cleaned.positions[0], cleaned.positions[-1], len(cleaned)) == (pytest.approx(first, abs=1e-9),
                                                                           pytest.approx(last, abs=1e-9), n)
    # independently: the plates' readings (near 47 mm) all lie outside what is kept, within 70 mm
    # of the ends, and the one nearest the road at most the margin and a few drop-outs away
    on_plate = p.positions[p.heights > 0.04]
    assert on_plate.size > 0 and np.all((on_plate < first) | (on_plate > last))
    assert np.all((on_plate < 0.07) | (on_plate > p.positions[-1] - 0.07))
    assert first - on_plate[on_plate < first].max() < MARGIN + 0.5e-3
    assert on_plate[on_plate > last].min() - last < MARGIN + 0.5e-3


@pytest.mark.parametrize("grade", [0.025, -0.025])
def test_captif_plates_on_a_graded_road_are_trimmed_as_on_the_level(captif_file: Path, grade: float) -> None:
    # the same real file tilted at 2.5 % (its far end 48 mm higher or lower): the same road is kept
    p = read_profile(captif_file)
    level = p.trim_reference_plates()
    tilted = with_shape(p, grade * p.positions).trim_reference_plates()
    np.testing.assert_array_equal(tilted.positions, level.positions)
