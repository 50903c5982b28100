"""Row detection on hard synthetic vineyards: young vines (canopy 0.3-0.8 m over the ground) and
grass between the rows. Each case either finds every row within the synthetic bounds (count exact, lateral error
<= 10 cm) or refuses with the evidence; it never reports rows on the grass strips (README "Rows and spray
plans" states which cases are which)."""

from __future__ import annotations

import pytest

from vinecli.rows.detect import NoRowsError, detect_rows_grid

from .row_fields import Field, match_rows

#: 40 m x 30 m at 5 cm, rows 2.2-2.4 m apart
FOUND = {
    # a young hedge: continuous canopy 0.4 m tall, 0.5 m wide, two gaps, on a 6 % slope
    "young-hedge": Field(width_m=40, height_m=30, res_m=0.05, direction_deg=17.0, spacing_m=2.4, n_rows=10,
                         t_range=(-17, 17), canopy_m=0.4, canopy_half_m=0.25, noise_m=0.02, slope=(0.06, 0.02),
                         gaps=[(-3, -2), (6, 7.5)], seed=1),
    # grown vines 1.4 m tall with a clumpy grass strip (0-0.3 m) down the middle of every inter-row
    "grass-between-rows": Field(width_m=40, height_m=30, res_m=0.05, direction_deg=-25.0, spacing_m=2.2, n_rows=11,
                                t_range=(-17, 17), canopy_m=1.4, canopy_half_m=0.35, noise_m=0.02, grass_m=0.15,
                                seed=3),
}

#: cases the detector refuses, with the phrase of the evidence it must give
REFUSED = {
    # young vines as single plants 0.5 m tall, 0.4 m across, 1.1 m apart, 15 % missing: the comb explains < 30 %
    # of the relief (most of it is plant-vs-gap along the rows)
    "young-sparse": (Field(width_m=40, height_m=30, res_m=0.05, direction_deg=17.0, spacing_m=2.4, n_rows=10,
                           t_range=(-17, 17), canopy_m=0.5, canopy_half_m=0.2, plants_m=1.1, plant_frac=0.2,
                           missing=0.15, noise_m=0.02, slope=(0.06, 0.02), seed=1), "cannot tell|no row"),
    # the same young vines with grass strips 0-0.4 m between them: the grass has the larger mean relief, so the
    # comb runs along the grass; the tallest plants are between its lines
    "young-sparse-in-grass": (Field(width_m=40, height_m=30, res_m=0.05, direction_deg=62.0, spacing_m=2.4, n_rows=9,
                                    t_range=(-15, 15), canopy_m=0.5, canopy_half_m=0.2, plants_m=1.1, plant_frac=0.2,
                                    missing=0.1, noise_m=0.02, grass_m=0.2, seed=4),
                              "taller plants between them.*cannot tell the rows from the inter-rows"),
    # a young hedge 0.6 m tall in clumpy grass 0-0.3 m: the grass's clumps leave the comb < 30 % of the relief
    "young-hedge-in-grass": (Field(width_m=40, height_m=30, res_m=0.05, direction_deg=62.0, spacing_m=2.4, n_rows=9,
                                   t_range=(-15, 15), canopy_m=0.6, canopy_half_m=0.3, noise_m=0.02, grass_m=0.15,
                                   seed=4), "no row pattern"),
}


@pytest.mark.parametrize("name", list(FOUND))
def test_young_vines_and_grass_found_within_bounds(name: str) -> None:
    f = FOUND[name]
    d = detect_rows_grid(*f.heights())
    assert len(d.rows) == f.n_rows
    matches = match_rows(d.rows, f.truth())
    assert sorted(k for k, _, _ in matches) == list(range(f.n_rows))
    assert max(err for _, err, _ in matches) <= 0.10
    assert min(ratio for _, _, ratio in matches) >= 0.75  # rows over their length inside the grid
    assert d.spacing_m == pytest.approx(f.spacing_m, rel=0.01)
    assert d.confidence >= 0.8


@pytest.mark.parametrize("name", list(REFUSED))
def test_young_vines_the_dsm_cannot_resolve_are_refused_with_the_evidence(name: str) -> None:
    f, phrase = REFUSED[name]
    with pytest.raises(NoRowsError, match=phrase) as exc:
        detect_rows_grid(*f.heights())
    ev = exc.value.evidence
    assert ev is not None and ev.spacing_m == pytest.approx(f.spacing_m, rel=0.01)  # the right pattern, named
    assert exc.value.exit_code == 2
    assert "best periodic pattern 2.4" in str(exc.value)


def test_narrow_canopies_are_measured_at_their_fundamental_not_a_harmonic() -> None:
    """Young hedges 0.5 m wide, 2.4 m apart: the 2-D spectrum's sharpest peak is the 4th harmonic (0.6 m); the
    detector reports the rows' spacing, 2.40 m, never a harmonic (it found 2 rows 1.20 m apart before)."""
    f = Field(width_m=40, height_m=30, res_m=0.05, direction_deg=17.0, spacing_m=2.4, n_rows=10, t_range=(-17, 17),
              canopy_m=0.5, canopy_half_m=0.25, plants_m=0.8, plant_frac=0.4, missing=0.1, noise_m=0.02,
              slope=(0.06, 0.02), seed=1)
    try:
        d = detect_rows_grid(*f.heights())
    except NoRowsError as exc:
        assert exc.evidence is not None and exc.evidence.spacing_m == pytest.approx(2.4, rel=0.01)
    else:
        assert d.spacing_m == pytest.approx(2.4, rel=0.01) and len(d.rows) == f.n_rows

