"""The points of a study (shellcontact.studies.sampling): grids, Latin hypercubes, Monte Carlo samples, CSV tables; and
the rank correlation the sensitivity figure shows. The distributions are checked against scipy.stats."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from shellcontact.errors import InputError
from shellcontact.studies.parametric import rank_correlation
from shellcontact.studies.sampling import grid, latin_hypercube, monte_carlo, parse_spec, read_points, sample

SPECS = ["shell.thickness=uniform(0.2,0.3)", "material.young=normal(4.32e8,2e7)", "shell.radius=lognormal(25,0.1)"]


def scipy_distribution(spec):
    """The distribution from scipy, independent of sampling's own."""
    if spec.dist == "uniform":
        return stats.uniform(spec.a, spec.b - spec.a)
    if spec.dist == "normal":
        return stats.norm(spec.a, spec.b)
    return stats.lognorm(s=spec.b, scale=spec.a)


def cdf(spec, x: float) -> float:
    return scipy_distribution(spec).cdf(x)


def test_grid_is_every_combination_first_key_slowest() -> None:
    specs = [parse_spec("punch.0.indentation=1e-3:3e-3:3"), parse_spec("shell.thickness=0.2,0.3")]
    points = grid(specs)
    assert len(points) == 6
    assert points[:2] == [{"punch.0.indentation": 1e-3, "shell.thickness": 0.2},
                          {"punch.0.indentation": 1e-3, "shell.thickness": 0.3}]
    assert {(p["punch.0.indentation"], p["shell.thickness"]) for p in points} == {
        (d, t) for d in (1e-3, 2e-3, 3e-3) for t in (0.2, 0.3)}


@pytest.mark.parametrize("n", [1, 7, 50])
def test_latin_hypercube_puts_one_point_in_every_stratum_of_every_key(n: int) -> None:
    specs = [parse_spec(s) for s in SPECS]
    points = latin_hypercube(specs, n, seed=11)
    assert len(points) == n
    for spec in specs:
        strata = sorted(math.floor(cdf(spec, p[spec.key]) * n) for p in points)
        assert strata == list(range(n)), spec.key


def test_samples_are_reproducible_from_the_seed() -> None:
    specs = [parse_spec(s) for s in SPECS]
    for draw in (latin_hypercube, monte_carlo):
        assert draw(specs, 20, seed=5) == draw(specs, 20, seed=5)
        assert draw(specs, 20, seed=5) != draw(specs, 20, seed=6)
    assert sample(specs, "lhs", 20, 5) == latin_hypercube(specs, 20, 5)


def test_monte_carlo_follows_the_distributions() -> None:
    """4000 draws: a Kolmogorov–Smirnov test against scipy's distribution of each key passes."""
    specs = [parse_spec(s) for s in SPECS]
    points = monte_carlo(specs, 4000, seed=2)
    for spec in specs:
        xs = np.array([p[spec.key] for p in points])
        assert stats.kstest(xs, scipy_distribution(spec).cdf).pvalue > 1e-3
    # independent draws: the keys are uncorrelated
    t = [p["shell.thickness"] for p in points]
    r = [p["shell.radius"] for p in points]
    assert abs(stats.spearmanr(t, r).statistic) < 4 / math.sqrt(4000)


@pytest.mark.parametrize("item, field, words", [
    ("shell.thickness=gamma(1,2)", "-p shell.thickness", "unknown distribution"),
    ("shell.thickness=uniform(0.3,0.2)", "-p shell.thickness", "lo < hi"),
    ("shell.thickness=normal(0.3,-1)", "-p shell.thickness", "standard deviation > 0"),
    ("shell.thickness=lognormal(0,0.1)", "-p shell.thickness", "median > 0"),
    ("shell.thickness=normal(0.3)", "-p shell.thickness", "two numbers"),
    ("shell.thickness=0.2:0.3", "-p shell.thickness", "start:stop:count"),
    ("shell.thickness", "-p", "KEY=SPEC"),
])
def test_bad_specs_name_the_key(item: str, field: str, words: str) -> None:
    with pytest.raises(InputError) as err:
        parse_spec(item)
    assert err.value.field == field and words in err.value.message


def test_sampling_refuses_mixed_specs() -> None:
    with pytest.raises(InputError, match="--sample lhs"):
        grid([parse_spec("shell.thickness=uniform(0.2,0.3)")])
    with pytest.raises(InputError, match="needs a distribution"):
        latin_hypercube([parse_spec("shell.thickness=0.2,0.3")], 4)
    with pytest.raises(InputError, match="--samples"):
        sample([parse_spec("shell.thickness=uniform(0.2,0.3)")], "mc")


def test_csv_points(tmp_path: Path) -> None:
    table = tmp_path / "points.csv"
    table.write_text('punch.0.indentation,solver.method\n1e-3,"""dual"""\n2e-3,\n\n3e-3,active-set\n')
    assert read_points(table) == [{"punch.0.indentation": 1e-3, "solver.method": "dual"},
                                  {"punch.0.indentation": 2e-3},
                                  {"punch.0.indentation": 3e-3, "solver.method": "active-set"}]
    table.write_text("punch.0.indentation,shell.thickness\n1e-3\n")
    with pytest.raises(InputError, match="line 2: 1 cells for 2 keys"):
        read_points(table)
    with pytest.raises(InputError, match="cannot read"):
        read_points(tmp_path / "missing.csv")


def test_rank_correlation_is_spearmans() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(size=40)
    y = x**3 + 0.3 * rng.normal(size=40)
    ties = np.round(y, 0)  # many ties: average ranks
    for a, b in ((x, y), (x, ties), (ties, x)):
        assert rank_correlation(list(a), list(b)) == pytest.approx(stats.spearmanr(a, b).statistic, abs=1e-12)
    assert rank_correlation(list(x), list(np.exp(x))) == pytest.approx(1.0, abs=1e-15)  # monotone: exactly 1
    assert rank_correlation([1.0, 1.0, 1.0], [1.0, 2.0, 3.0]) is None


def test_grid_keeps_integers_and_refuses_a_grid_too_large_to_record() -> None:
    points = sample([parse_spec("mesh.refine=0:2:3")], "grid")
    assert points == [{"mesh.refine": 0}, {"mesh.refine": 1}, {"mesh.refine": 2}]
    assert all(type(p["mesh.refine"]) is int for p in points)  # an integer key's values stay integers
    specs = [parse_spec(f"shell.{k}=0:1:10000") for k in ("thickness", "radius", "length")]
    t0 = time.perf_counter()
    with pytest.raises(InputError) as err:
        sample(specs, "grid", max_memory="1G")  # 1e12 points: refused before the product is built
    assert err.value.field == "-p" and time.perf_counter() - t0 < 0.5
    with pytest.raises(InputError, match="--samples"):
        sample([parse_spec("shell.thickness=uniform(0.2,0.3)")], "mc", 10**12, max_memory="1G")


def test_a_value_list_of_words() -> None:
    spec = parse_spec("solver.method=active-set,dual")
    assert grid([spec, parse_spec("mesh.refine=0,1")])[1:3] == [{"solver.method": "active-set", "mesh.refine": 1},
                                                              {"solver.method": "dual", "mesh.refine": 0}]
    with pytest.raises(InputError, match="start:stop:count"):
        parse_spec("shell.thickness=0.2,dual")  # numbers and words: a typo, not a list of words
