"""Materials read from an FE tool's input file (issue 28): Abaqus/CalculiX *MATERIAL and
*SOLID SECTION, Nastran MAT1 and PSOLID in free, small and large field, scaled from the
file's consistent units (mm, t, s: MPa, t/mm^3) to SI."""

from __future__ import annotations

import pytest

from pipeline.core.errors import ConfigError
from pipeline.meshing.file_materials import read_file_materials

MM, T = 1e-3, 1000.0  # m and kg per file unit

INP = """*HEADING
** a comment
*NODE, NSET=NALL
1, 0, 0, 0
*MATERIAL, NAME=Steel
*ELASTIC
210000., 0.3
*DENSITY
7.85e-09
*EXPANSION
1.2e-5
*material, name=ALU
*density
2.7e-9
*elastic, type=isotropic
70000, 0.33, 20.
71000, 0.33, 100.
*SOLID SECTION, ELSET=NEAR, MATERIAL=STEEL
*Solid Section, elset=FAR, material=alu
*STEP
*FREQUENCY
6
*END STEP
"""

# small field (8 characters), free field, large field with its continuation
BDF = ("BEGIN BULK\n"
       "$ steel: E, G blank, NU, RHO in Nastran's reals\n"
       "MAT1    1       2.1+5           .3      7.85-9\n"
       "MAT1,2,,26315.79,0.33,2.7-9\n"
       "MAT1*   3               1.7E+05         6.5385E+04      \n"
       "*       7.2-9\n"
       "PSOLID  1       1\n"
       "PSOLID,2,2\n"
       "PSOLID  7       3\n"
       "ENDDATA\n")


def test_abaqus_materials_of_solid_sections_in_si(tmp_path):
    path = tmp_path / "part.inp"
    path.write_text(INP)
    got = read_file_materials(path, "abaqus", MM, T)
    assert set(got) == {"NEAR", "FAR"}
    assert got["NEAR"] == pytest.approx((210e9, 0.3, 7850.0), rel=1e-12)
    # the first row of a temperature table
    assert got["FAR"] == pytest.approx((70e9, 0.33, 2700.0), rel=1e-12)
    assert read_file_materials(path, "abaqus", 1.0, 1.0)["NEAR"] == \
        pytest.approx((210000.0, 0.3, 7.85e-9))


def test_nastran_mat1_and_psolid_in_three_field_formats(tmp_path):
    path = tmp_path / "part.bdf"
    path.write_text(BDF)
    got = read_file_materials(path, "nastran", MM, T)
    assert set(got) == {"PID1", "PID2", "PID7"}
    assert got["PID1"] == pytest.approx((210e9, 0.3, 7850.0), rel=1e-12)
    # E from G and NU: 2 G (1 + nu)
    assert got["PID2"] == pytest.approx((2 * 26315.79e6 * 1.33, 0.33, 2700.0), rel=1e-12)
    # NU from E and G: E / (2 G) - 1
    assert got["PID7"] == pytest.approx((170e9, 1.7e5 / (2 * 6.5385e4) - 1, 7200.0), rel=1e-12)


@pytest.mark.parametrize("text, fmt, message", [
    (INP.replace("*DENSITY\n7.85e-09\n", ""), "abaqus",
     r"part\.inp:5: \*MATERIAL, NAME=STEEL: has no rho"),
    (INP.replace("material=alu", "material=brass"), "abaqus",
     r"part\.inp:19: \*SOLID SECTION, ELSET=FAR: material 'BRASS' is not defined"),
    (INP.replace("*ELASTIC\n", "*ELASTIC, TYPE=ORTHOTROPIC\n"), "abaqus",
     r"part\.inp:6: \*ELASTIC, TYPE=ORTHOTROPIC: the FE stage takes isotropic"),
    (INP.replace("210000., 0.3", "210000., stiff"), "abaqus",
     r"part\.inp:7: \*ELASTIC: expected numbers, got '210000\., stiff'"),
    ("*NODE\n1, 0, 0, 0\n", "abaqus", r"part\.inp: has no solid section"),
    (BDF.replace("PSOLID,2,2", "PSOLID,2,9"), "nastran",
     r"part\.inp:8: PSOLID 2: material 9 \(MAT1\) is not defined"),
    (BDF.replace("7.85-9", "heavy "), "nastran", r"part\.inp:3: MAT1 RHO: expected a number"),
    (BDF.replace("MAT1,2", "MAT9,2"), "nastran", r"part\.inp:4: MAT9: the FE stage takes"),
    ("$ empty\n", "vtu", r"not from vtu files"),
])
def test_bad_material_cards_name_file_and_line(tmp_path, text, fmt, message):
    path = tmp_path / "part.inp"
    path.write_text(text)
    with pytest.raises(ConfigError, match=message):
        read_file_materials(path, fmt, MM, T)
