"""Griffiths & Lane (1999), example 1: a homogeneous 2:1 slope with no foundation layer
(``validation/cases/griffiths_lane_1999_ex1.toml``), a slope of the published record with a
finite-element strength-reduction result of its own. SPH strength reduction against the
package's Bishop (critical circle) and against the published values: finite-element strength
reduction 1.4 (Griffiths & Lane 1999, Geotechnique 49(3) 387-403) and Bishop & Morgenstern's
(1960) charts 1.380, both quoted in that paper."""

from validation.common import REPO
from validation.slope_fos import Slope, validate_slope

SLOPE = Slope(
    "griffiths_lane_1999_ex1", "clay", ladder=(0.5, 0.25), quick_ladder=(0.5,),
    path=REPO / "validation" / "cases" / "griffiths_lane_1999_ex1.toml",
    published={"Griffiths & Lane 1999, finite-element strength reduction": 1.4,
               "Bishop & Morgenstern 1960 charts (quoted by Griffiths & Lane)": 1.380},
    reference_fe="Griffiths & Lane 1999, finite-element strength reduction",
    reference="finite-element strength reduction 1.4 (Griffiths & Lane 1999, example 1)")


def validate(quick=False, data_dir=None, out_dir=None):
    return validate_slope(SLOPE, quick, out_dir)
