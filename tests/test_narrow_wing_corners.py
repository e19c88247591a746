"""A corner part in a wing narrower than the part is deep (a C- or L-shaped building of
Helsinki, 12 m wings, the sample corner parts 14 m deep): the corner's arm ran on
through the modules of the wing's far side, two masses in one place, roofs
z-fighting (60 m² shared on feature 45). Corner parts were split and cut on medial
planes only against another ring (a courtyard); now also against the stages of their
own ring that share no key point with either of their legs (export/place.py,
``_Placer._medial_cuts`` -> ``_medial_corner``), and a plane that opens the roof is
given back as for courtyards (``_reopen``)."""

from __future__ import annotations

import pytest

from citysynth.export.audit import audit_usd
from tests.footprint_build import DEPTH, build_feature, helsinki_feature


@pytest.mark.parametrize("feature, shared_before, gap_before",
                         [(45, 60.4, 0.0), (233, 47.8, 87.1)])
def test_corner_parts_stop_at_the_far_side_of_a_narrow_wing(tmp_path, feature,
                                                            shared_before, gap_before):
    """Shipped Helsinki footprints whose corner parts overlapped the far side of their
    wing (ground two instances shared, and the roof-band gap, before, m²)."""
    usd, lay = build_feature(tmp_path, helsinki_feature(feature))
    assert any(i["class"] == "corner" for i in lay["instances"])
    a = audit_usd(usd, lay["structures"], DEPTH)
    print(f"\nfeature {feature}: overlap {a.overlap:.2f} m² (was {shared_before}), band gap "
          f"{a.band_gap:.1f} m² (was {gap_before}), beyond {a.beyond_max:.2f} m")
    assert a.overlap <= 0.25 * shared_before
    assert a.band_gap <= gap_before + 20.0      # a triangle may open where planes cross
    assert a.beyond_max <= 0.7
