"""OpenCRG headers that contradict their data or themselves (roadtex.surfaces.readers.check_crg_header):
the OpenCRG library places the data by the header's start and increment and ignores the ends it
states, so a wrong increment, a truncated data section or a sign slip was read as stated, without a
word. Files written by pycrg (ASCII LRFI, so that the header can be edited as text)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from roadtex.errors import CoarseSamplingWarning, ProfileFormatError
from roadtex.surfaces import read_surface

pycrg = pytest.importorskip("pycrg")

NU, NV = 341, 5   # 341 cross sections 10 mm apart: 3.4 m; 5 long sections 2 mm apart


def crg_text(tmp_path: Path) -> bytes:
    z = np.random.default_rng(8).normal(0.0, 1e-3, (NU, NV))
    v = np.linspace(-0.004, 0.004, NV)
    pycrg.write(tmp_path / "written.crg", z, 0.01, v, 0.0, mods={}, comment="roadtex test", fmt="LRFI")
    return (tmp_path / "written.crg").read_bytes()


def edited(tmp_path: Path, key: str, value: str, name: str = "road.crg") -> Path:
    text = crg_text(tmp_path)
    changed, count = re.subn(rf"{key}\s*=\s*\S+".encode(), f"{key} = {value}".encode(), text)
    assert count == 1
    (tmp_path / name).write_bytes(changed)
    return tmp_path / name


def test_an_unedited_file_reads(tmp_path: Path) -> None:
    (tmp_path / "road.crg").write_bytes(crg_text(tmp_path))
    with pytest.warns(CoarseSamplingWarning):   # 10 mm, certain in OpenCRG: read as it is
        surface = read_surface(tmp_path / "road.crg")
    assert surface.shape == (NV, NU) and surface.dy == pytest.approx(0.002)


@pytest.mark.parametrize("key, value, words", [
    # the case: 1e-9 m across, while the header puts the left long section 8 mm from the right one
    ("long_section_v_increment", "1.0e-09", "long_section_v_left is 0.004 m, but its 5 long sections from -0.004 m "
                                            "at long_section_v_increment 1e-09 m end at -0.004 m"),
    ("reference_line_increment", "1.0e-09", "reference_line_end_u is 3.4 m, but its 341 cross sections from 0 m at "
                                            "reference_line_increment 1e-09 m end at 3.4e-07 m"),
    ("reference_line_end_u", "1000.0", "reference_line_end_u is 1000 m, but its 341 cross sections"),
    ("long_section_v_left", "0.4", "long_section_v_left is 0.4 m"),
    ("long_section_v_increment", "-0.002", "not increasing"),
    ("reference_line_increment", "-0.01", "reference_line_increment is -0.01 m"),
    ("reference_line_start_u", "inf", "not finite"),
])
def test_a_header_contradicting_its_data_is_refused_naming_both_figures(tmp_path: Path, key: str, value: str,
                                                                        words: str) -> None:
    with pytest.raises(ProfileFormatError, match=re.escape(words)) as caught:
        read_surface(edited(tmp_path, key, value))
    assert str(caught.value).startswith("road.crg: ")


def test_a_truncated_data_section_is_refused(tmp_path: Path) -> None:
    text = crg_text(tmp_path)
    (tmp_path / "cut.crg").write_bytes(text[:len(text) - 3000])   # pycrg's library reads the rows that remain
    with pytest.raises(ProfileFormatError, match=r"cut\.crg: the header contradicts its data: reference_line_end_u is "
                                                 r"3\.4 m, but its \d+ cross sections"):
        read_surface(tmp_path / "cut.crg")


def test_a_u_channel_increment_other_than_the_headers_is_refused(tmp_path: Path) -> None:
    text = crg_text(tmp_path).replace(b"U:reference line u,m,0.0,0.01", b"U:reference line u,m,0.0,0.02")
    (tmp_path / "u.crg").write_bytes(text)
    with pytest.raises(ProfileFormatError, match="reference_line_increment is 0.01 m, the U channel's increment "
                                                 r"\(\$KD_DEFINITION\) 0.02 m"):
        read_surface(tmp_path / "u.crg")


def test_an_increment_across_of_1e9_without_a_stated_end_is_judged_implausible(tmp_path: Path) -> None:
    from roadtex.errors import ImplausibleTextureWarning

    text = re.sub(rb"long_section_v_left\s*=\s*\S+\n", b"", crg_text(tmp_path))
    text = re.sub(rb"long_section_v_increment\s*=\s*\S+", b"long_section_v_increment = 1.0e-09", text)
    (tmp_path / "thin.crg").write_bytes(text)
    with pytest.warns(ImplausibleTextureWarning, match=r"thin\.crg: its 5 rows across the road are 1e-09 m apart"):
        read_surface(tmp_path / "thin.crg")
