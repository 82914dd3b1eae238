"""Synthetic pavements: MPD in the ranges typical of each surface, spectra, reproducibility."""

from __future__ import annotations

import numpy as np
import pytest

from roadtex.profiles import Profile, mpd, read_profile
from roadtex.profiles.pavements import synthetic_pavement
from roadtex.spectra import third_octave_levels

# (kind, options, MPD range in mm) as stated in roadtex.pavements' docstring (Sandberg & Ejsmont 2002,
# PIARC, FHWA)
RANGES = [
    ("dense_asphalt", {}, (0.5, 1.0)),
    ("porous_asphalt", {}, (1.2, 2.0)),
    ("surface_dressing", {}, (1.5, 3.0)),
    ("cement_concrete", {}, (0.3, 0.6)),
    ("cement_concrete", {"tining": True}, (0.6, 1.2)),
]


@pytest.mark.parametrize("kind, options, mpd_range", RANGES, ids=[f"{k}{'-tined' if o else ''}" for k, o, _ in RANGES])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_mpd_lands_in_the_range_typical_of_the_surface(kind, options, mpd_range, seed):
    profile = synthetic_pavement(kind, 1.0, 0.25e-3, seed=seed, **options)
    result = mpd(profile)
    low, high = mpd_range
    assert low * 1e-3 <= result.mpd <= high * 1e-3
    assert result.valid_segments == len(result.segments) == 10   # clean synthetic data: no spike, no drop-out


@pytest.mark.parametrize("kind", ["dense_asphalt", "porous_asphalt", "surface_dressing", "cement_concrete"])
def test_same_seed_reproduces_and_other_seeds_differ(kind):
    a = synthetic_pavement(kind, 0.2, 0.1e-3, seed=5)
    b = synthetic_pavement(kind, 0.2, 0.1e-3, seed=5)
    c = synthetic_pavement(kind, 0.2, 0.1e-3, seed=6)
    np.testing.assert_array_equal(a.heights, b.heights)
    assert np.max(np.abs(a.heights - c.heights)) > 1e-4
    assert a.is_uniform and not np.isnan(a.heights).any() and len(a) == 2000
    assert a.metadata["kind"] == kind and a.metadata["seed"] == 5 and a.metadata["synthetic"] is True
    assert abs(a.heights.mean()) < 1e-15


def test_kinds_differ_from_each_other_with_the_same_seed():
    dense = synthetic_pavement("dense_asphalt", 0.2, 0.1e-3, seed=1).heights
    porous = synthetic_pavement("porous_asphalt", 0.2, 0.1e-3, seed=1).heights
    assert np.corrcoef(dense, porous)[0, 1] < 0.5


def skewness(z: np.ndarray) -> float:
    centred = z - z.mean()
    return float(np.mean(centred**3) / np.mean(centred**2) ** 1.5)


def test_porous_asphalt_is_negative_texture_unlike_the_others():
    # negative texture: a plateau with deep pores, so the heights are strongly skewed downwards
    porous = skewness(synthetic_pavement("porous_asphalt", 1.0, 0.1e-3, seed=0).heights)
    assert porous < -1.0
    for kind in ("dense_asphalt", "surface_dressing", "cement_concrete"):
        assert skewness(synthetic_pavement(kind, 1.0, 0.1e-3, seed=0).heights) > porous + 0.8


def third_octave_texture_levels(profile: Profile, *, shortest: float = 0.5e-3,
                                longest: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """(centre wavelengths (m), levels (dB re 1 um)) of the bands roadtex.spectra reports."""
    table = third_octave_levels(profile.heights, profile.dx)
    table = table.filter(table["reported"] & (table["centre_wavelength"] >= shortest * 0.99)
                         & (table["centre_wavelength"] <= longest * 1.01)).sort("centre_wavelength")
    return table["centre_wavelength"].to_numpy(), table["level_db"].to_numpy()


@pytest.mark.parametrize("kind, peak_range_mm", [("dense_asphalt", (5.0, 13.0)), ("porous_asphalt", (9.0, 21.0)),
                                                 ("surface_dressing", (9.0, 26.0))])
def test_spectra_peak_at_the_aggregate_size(kind, peak_range_mm):
    centres, levels = third_octave_texture_levels(synthetic_pavement(kind, 3.0, 0.5e-3, seed=0), longest=0.05)
    peak = centres[np.argmax(levels)] * 1e3
    assert peak_range_mm[0] <= peak <= peak_range_mm[1]
    assert 38 < levels.max() < 62


def test_tining_puts_a_tonal_peak_at_its_spacing():
    plain = synthetic_pavement("cement_concrete", 3.0, 0.5e-3, seed=0)
    tined = synthetic_pavement("cement_concrete", 3.0, 0.5e-3, seed=0, tining=True, tining_spacing=20e-3,
                               tining_spacing_jitter=0.0)
    centres, plain_levels = third_octave_texture_levels(plain)
    _, tined_levels = third_octave_texture_levels(tined)
    band = int(np.argmin(np.abs(np.log(centres / 20e-3))))
    assert tined_levels[band] > plain_levels[band] + 15
    assert tined_levels[band] >= tined_levels.max() - 1.0


def iso_conditioned(profile):
    """ISO 13473-1's chain at 0.5 mm with the CAPTIF authors' spike alpha (6), as the generator was tuned."""
    return (profile.trim_reference_plates().resample(0.5e-3).remove_spikes(6.0).fill_dropouts().detrend())


def test_synthetic_chip_seal_spectrum_is_near_the_real_captif_chip_seals(captif_dir):
    captif_files = sorted(captif_dir.glob("*.dat"))
    synthetic = synthetic_pavement("surface_dressing", 1.8, 0.5e-3, seed=0)
    _, synthetic_levels = third_octave_texture_levels(synthetic, shortest=2e-3, longest=20e-3)
    real = [third_octave_texture_levels(iso_conditioned(read_profile(p)), shortest=2e-3, longest=20e-3)[1]
            for p in captif_files]
    real_mean = np.mean(real, axis=0)
    # within 6 dB in every band from 2 to 20 mm: same kind of surface, not the same surface
    assert np.max(np.abs(synthetic_levels - real_mean)) < 6.0
    real_skewness = [skewness(iso_conditioned(read_profile(p)).heights) for p in captif_files]
    assert min(real_skewness) - 0.3 < skewness(synthetic.detrend().heights) < max(real_skewness) + 0.3


@pytest.mark.parametrize(
    "args, options, message",
    [
        (("asphalt", 1.0, 1e-3), {}, "unknown pavement kind"),
        (("dense_asphalt", 1.0, 0.0), {}, "dx must be a positive finite number"),
        (("dense_asphalt", 1e-3, 1e-3), {}, "fewer than 10 samples"),
        (("dense_asphalt", 1.0, 1e-3), {"tining": True}, "unknown option"),
        (("dense_asphalt", 1.0, 1e-3), {"max_stone": -1.0}, ">= 0"),
        (("dense_asphalt", 1.0, 1e-3), {"min_stone": 0.02}, "min_stone <= max_stone"),
        (("cement_concrete", 1.0, 1e-3), {"tining": "yes"}, "True or False"),
        (("cement_concrete", 1.0, 1e-3), {"tining": True, "tining_spacing": 2e-3}, "must exceed tining_width"),
    ],
)
def test_bad_arguments_are_refused(args, options, message):
    with pytest.raises(ValueError, match=message):
        synthetic_pavement(*args, **options)


def test_bad_seed_is_refused():
    with pytest.raises(ValueError, match="seed"):
        synthetic_pavement("dense_asphalt", 1.0, 1e-3, seed=-1)
