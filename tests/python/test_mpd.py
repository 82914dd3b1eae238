"""Mean profile depth: analytic profiles with known MPD, validity rules, real CAPTIF files, the peer."""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from roadtex.errors import InvalidInputError
from roadtex.profiles import Profile, mpd, read_profile
from roadtex.profiles.mpd import estimated_texture_depth

REPO = Path(__file__).resolve().parents[2]
PEER_VENV = REPO / ".venv-peers"

DX = 0.5e-3


def cosine(amplitude: float = 1e-3, wavelength: float = 10e-3, length: float = 1.0, dx: float = DX) -> Profile:
    """Samples at (k + 1/2) dx: every 100 mm segment is then mirror-symmetric about its centre, so
    its least-squares slope is exactly 0, and the highest sample sits dx/2 from a crest."""
    x = dx * (np.arange(int(round(length / dx))) + 0.5)
    return Profile.from_heights(amplitude * np.cos(2 * np.pi * x / wavelength), dx, start=0.5 * dx)


def sampled_crest(amplitude: float, wavelength: float) -> float:
    return amplitude * math.cos(math.pi * DX / wavelength)


def test_mpd_of_a_cosine_is_its_sampled_amplitude():
    # each half segment holds whole periods: both peaks are the highest sample, the mean is 0
    result = mpd(cosine(1e-3), lowpass_wavelength=None)
    assert result.mpd == pytest.approx(sampled_crest(1e-3, 10e-3), rel=1e-9)
    assert result.valid_segments == len(result.segments) == 10 and result.is_valid
    np.testing.assert_allclose(result.msd, sampled_crest(1e-3, 10e-3), rtol=1e-9)


def test_the_lowpass_filter_scales_mpd_by_its_analytic_gain():
    wavelength, cutoff = 5e-3, 2.4e-3
    ratio = math.tan(math.pi * DX / wavelength) / math.tan(math.pi * DX / cutoff)
    gain = 1 / (1 + ratio**4)
    result = mpd(cosine(1e-3, wavelength, length=2.0), lowpass_wavelength=cutoff)
    inner = result.msd[1:-1]     # the outer segments feel the filter's end conditions
    np.testing.assert_allclose(inner, sampled_crest(1e-3, wavelength) * gain, rtol=1e-6)
    assert gain < 0.98           # the check has teeth: the filter takes 3 % at 5 mm


def test_mpd_of_a_plateau_with_narrow_pores_is_depth_times_pore_share():
    # negative texture: peak 0, mean -D w / P, so MSD = D w / P exactly
    period, width, depth = 10e-3, 2e-3, 6e-3
    x = DX * np.arange(2000)
    phase = np.mod(x + 0.5 * DX, period)
    z = np.where(np.abs(phase - 0.5 * period) < 0.5 * width, -depth, 0.0)
    result = mpd(Profile.from_heights(z, DX), lowpass_wavelength=None, spike_alpha=None)
    assert result.mpd == pytest.approx(depth * width / period, rel=1e-9)


def test_slope_suppression_removes_a_linear_trend():
    """MSD is blind to a straight line added to the profile (ISO 13473-1 removes each segment's
    least-squares line): the tilted cosine gives the untilted one's peaks and mean, segment by
    segment. Unsuppressed, a ramp s x would add s L / 4 to every segment's MSD (half-segment peaks
    s L / 2 and s L against a mean of s L / 2): 1.25 mm here, against the 1e-9 the MPD is held to."""
    slope = 0.05
    base = cosine(1e-3)
    tilted = Profile.from_heights(base.heights + slope * base.positions, DX, start=0.5 * DX)
    # plates are looked for as in any run: the 5 % grade (50 mm over the metre) is not one
    result = mpd(tilted, lowpass_wavelength=None)
    assert result.mpd == pytest.approx(sampled_crest(1e-3, 10e-3), rel=1e-9)
    level = mpd(base, lowpass_wavelength=None).segments
    assert len(result.segments) == len(level) == 10
    for column in ("peak_first_half", "peak_second_half", "mean_level"):
        np.testing.assert_allclose(result.segments[column], level[column], rtol=0, atol=1e-12, err_msg=column)
    # The tilt did reach the segments: every 100 mm of the profile they were cut from still rises
    # at s (least-squares fit by numpy; the cosine's own fit is 0 by symmetry).
    x, z = result.profile.positions, result.profile.heights
    for k in range(len(result.segments)):
        inside = (x >= 0.1 * k) & (x < 0.1 * (k + 1))
        assert np.polyfit(x[inside], z[inside], 1)[0] == pytest.approx(slope, rel=1e-6)


def test_highpass_slope_suppression_also_removes_long_waves():
    base = cosine(1e-3, length=3.0)
    wavy = Profile.from_heights(base.heights + 5e-3 * np.sin(2 * np.pi * base.positions / 2.0), DX)
    result = mpd(wavy, lowpass_wavelength=None, slope_suppression="highpass")
    assert result.mpd == pytest.approx(1e-3, rel=0.03)
    assert result.parameters["highpass_wavelength"] == 0.1742


def test_etd_follows_the_edition_named_2019_by_default():
    # 2019: ETD = 1.1 MPD; 1997: ETD = 0.2 mm + 0.8 MPD (both at a cosine whose MPD is known)
    depth = sampled_crest(0.8e-3, 10e-3)
    result = mpd(cosine(0.8e-3), lowpass_wavelength=None)
    assert result.etd == pytest.approx(1.1 * depth, rel=1e-9)
    assert result.parameters["etd_edition"] == "2019"
    old = mpd(cosine(0.8e-3), lowpass_wavelength=None, etd_edition="1997")
    assert old.etd == pytest.approx(0.2e-3 + 0.8 * depth, rel=1e-9)
    # the two editions agree at MPD = 2/3 mm only
    assert estimated_texture_depth(2e-3 / 3, "2019") == pytest.approx(estimated_texture_depth(2e-3 / 3, "1997"))


def test_an_unknown_etd_edition_is_refused():
    with pytest.raises(InvalidInputError, match="etd_edition"):
        mpd(cosine(0.8e-3), etd_edition="2004")


def triangle(amplitude: float, n: int = 2000, wavelength: float = 10e-3) -> np.ndarray:
    """A triangle wave sampled at (k + 1/2) dx, crests at multiples of the wavelength: each 50 mm
    half segment holds whole periods, the highest sample sits dx/2 below a crest (amplitude
    (1 - 2 dx / wavelength)), the mean is 0 and every segment is mirror-symmetric (slope 0). Between
    crest and trough it is straight, so linear interpolation over a drop-out there is exact."""
    phase = np.mod(DX * (np.arange(n) + 0.5), wavelength) / wavelength
    return amplitude * (1 - 4 * np.minimum(phase, 1 - phase))


def test_segments_with_too_many_dropouts_are_invalid_and_left_out():
    """MPD is the mean MSD of the valid segments, in closed form: 8 segments of the triangle wave
    (MSD 0.9 A, one of them with 5 % drop-outs inside straight flanks, filled exactly), one at
    three times the amplitude (2.7 A): (8 x 0.9 + 2.7) / 9 A = 1.1 A. The segment with 15 %
    drop-outs is invalid, and its remaining readings, five times the amplitude, must not count."""
    amplitude = 1e-3
    z = triangle(amplitude)
    z[200:200 + 30] = np.nan               # 15 % of segment 1 ...
    z[230:400] *= 5                        # ... whose remaining readings would raise the MPD
    z[401:406] = z[421:426] = np.nan       # 5 % of segment 2, inside falling flanks: still valid
    z[600:800] *= 3                        # segment 3 disturbed but complete
    result = mpd(Profile.from_heights(z, DX, start=0.5 * DX), lowpass_wavelength=None, spike_alpha=None)
    table = result.segments
    assert table["valid"].to_list() == [True, False] + [True] * 8
    assert table["dropout_fraction"][1] == pytest.approx(0.15)
    assert table["dropout_fraction"][2] == pytest.approx(0.05)
    crest = amplitude * (1 - 2 * DX / 10e-3)
    expected_msd = np.full(10, crest)
    expected_msd[3] = 3 * crest
    valid = table["valid"].to_numpy()
    np.testing.assert_allclose(result.msd[valid], expected_msd[valid], rtol=1e-9)
    assert result.msd[1] > 4 * crest       # so counting segment 1 would move the MPD by a third
    assert result.mpd == pytest.approx(1.1 * amplitude, rel=1e-9)
    assert result.valid_segments == 9


def test_spikes_are_removed_and_too_many_make_a_segment_invalid():
    base = cosine(1e-3).heights.copy()
    base[250] += 8e-3                       # one spike in segment 1
    spiky = Profile.from_heights(base, DX)
    assert mpd(spiky, lowpass_wavelength=None).msd[1] == pytest.approx(1e-3, rel=0.05)
    assert mpd(spiky, lowpass_wavelength=None, spike_alpha=None).msd[1] > 3e-3
    many = base.copy()
    many[600:800:10] += 8e-3                # 20 spikes, 60 flagged samples = 30 % of segment 3
    result = mpd(Profile.from_heights(many, DX), lowpass_wavelength=None)
    assert not result.segments["valid"][3] and result.segments["spike_fraction"][3] > 0.05


def test_a_result_with_few_valid_segments_is_flagged():
    z = cosine(1e-3, length=0.3).heights.copy()
    z[:400] = np.nan
    z[0] = 0.0
    result = mpd(Profile.from_heights(z, DX), lowpass_wavelength=None)
    assert result.valid_segments == 1 and not result.is_valid
    assert result.valid_fraction == pytest.approx(1 / 3)


def test_mpd_works_on_raw_uneven_profiles_with_dropouts():
    rng = np.random.default_rng(2)
    x = np.cumsum(rng.uniform(0.03e-3, 0.045e-3, 40000))
    z = 1e-3 * np.cos(2 * np.pi * x / 10e-3)
    z[rng.random(z.size) < 0.05] = np.nan
    result = mpd(Profile(z, x, float(np.mean(np.diff(x)))), lowpass_wavelength=None)
    assert result.mpd == pytest.approx(1e-3, rel=0.02)


@pytest.mark.parametrize(
    "options, message",
    [
        ({"sample_spacing": 0.0}, "sample_spacing"),
        ({"segment_length": 0.1003}, "whole number"),
        ({"spike_alpha": -1}, "spike_alpha"),
        ({"max_dropout_fraction": 1.5}, "between 0 and 1"),
        ({"slope_suppression": "none"}, "slope_suppression"),
    ],
)
def test_bad_settings_are_refused(options, message):
    with pytest.raises(ValueError, match=message):
        mpd(cosine(), **options)


def test_too_short_profiles_and_non_profiles_are_refused():
    with pytest.raises(ValueError, match="shorter than one 100 mm segment"):
        mpd(cosine(length=0.08))
    with pytest.raises(ValueError, match="Profile"):
        mpd(np.zeros(1000))  # type: ignore[arg-type]


# --------------------------------------------------------------------------------------------------
# the real CAPTIF chip seals, against captif-slp

# captif-slp's own test suite (tests/test_process.py) publishes these MPDs (mm) for the three files,
# computed by its process_files (alpha 6, plates detected, 0.5 mm, 100 mm segments).
PUBLISHED_PEER_MPD_MM = {
    "20211011_aylesbury_dec_station_0.dat": 3.2777511138235296,
    "20211011_aylesbury_dec_station_1.dat": 3.0331992396875003,
    "20211011_aylesbury_dec_station_10.dat": 3.420159709285714,
}


def test_real_chip_seals_match_the_peers_published_mpd_within_2_percent(captif_file):
    result = mpd(read_profile(captif_file), spike_alpha=6)
    expected = PUBLISHED_PEER_MPD_MM[captif_file.name] * 1e-3
    assert abs(result.mpd / expected - 1) < 0.02
    assert result.is_valid and len(result.segments) == 18


@pytest.mark.skipif(not (PEER_VENV / "bin" / "python").exists(),
                    reason="the captif-slp peer needs its own venv: create it with "
                           "'bash scripts/peer-captif-slp.sh install' (about a minute; it pins numpy < 2)")
def test_real_chip_seals_match_captif_slp_run_live_within_2_percent(captif_dir):
    files = sorted(captif_dir.glob("*.dat"))
    out = subprocess.run(["bash", str(REPO / "scripts" / "peer-captif-slp.sh"), "mpd", "--alpha", "6",
                          *map(str, files)], capture_output=True, text=True, timeout=300, check=True)
    peer = [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]
    assert len(peer) == len(files)
    for path, theirs in zip(files, peer):
        ours = mpd(read_profile(path), spike_alpha=6)
        assert abs(ours.mpd / (theirs["mpd_mm"] * 1e-3) - 1) < 0.02, path.name
        assert ours.valid_segments == theirs["valid_segments"], path.name
