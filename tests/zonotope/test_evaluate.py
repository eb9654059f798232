"""zonotope.evaluate and zonotope.spectra.atypical."""

from __future__ import annotations

import numpy as np
import pytest

from zonotope._errors import SpectralDataError
from zonotope.evaluate import TestSet, evaluate, natural_test_sets
from zonotope.spectra.atypical import ATYPICAL_KINDS, atypical_reflectances

GRID = np.arange(400.0, 701.0, 10.0)


def test_atypical_seeded_and_valid():
    A, labels = atypical_reflectances(GRID, 40, seed=7)
    B, _ = atypical_reflectances(GRID, 40, seed=7)
    assert np.array_equal(A, B)
    assert A.shape == (40, GRID.size) and A.min() >= 0 and A.max() <= 1
    assert {lab.rsplit(" ", 1)[0] for lab in labels} == set(ATYPICAL_KINDS)
    assert not np.array_equal(A, atypical_reflectances(GRID, 40, seed=8)[0])
    assert atypical_reflectances(GRID, 0)[0].shape == (0, GRID.size)
    with pytest.raises(ValueError, match="band-pass"):
        atypical_reflectances(GRID, 3, kinds=["rainbow"])


def test_evaluate_table():
    A, _ = atypical_reflectances(GRID, 6, seed=1)
    sets = [natural_test_sets(GRID)[0], TestSet("atypical", A, "atypical")]
    ev = evaluate(
        [["Nikon 5100 (NPL)"]],
        methods=["Finlayson 2015", "idt", "MAP", "Prior"],
        shape=GRID,
        test_sets=sets,
        noise=0,
    )
    methods = {r.method for r in ev.rows}
    assert {"Finlayson 2015", "Dyer 2017", "MAP", "Prior"} <= methods
    rp = next(r for r in ev.rows if r.method == "Finlayson 2015" and r.kind == "natural")
    assert rp.n == 24 - 7 and 0 < rp.median <= rp.p95 <= rp.max and rp.inside == 1.0  # 7 in training
    # exact share of answers outside the MMV of their responses, for every estimator (noise-free run)
    assert all(r.outside is not None and 0.0 <= r.outside <= 1.0 for r in ev.rows)
    assert set(ev.summary("atypical")) == methods
    md = ev.to_markdown()
    assert "| cameras | test set | estimator |" in md and "Prior" in md  # noise-free: no noise column
    assert "outside MMV (exact)" in md


def test_evaluate_skips_idt_for_two_cameras_and_rejects_empty_sets():
    sets = [TestSet("one", natural_test_sets(GRID)[0].reflectances[:3])]
    ev = evaluate(
        [["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"]],
        methods=["idt", "least squares"],
        shape=GRID,
        test_sets=sets,
        noise=0,
    )
    assert [r.method for r in ev.rows] == ["Cheung 2004"]
    assert any("Dyer 2017 skipped" in n for n in ev.notes)
    with pytest.raises(SpectralDataError, match="empty"):
        evaluate(["Nikon 5100 (NPL)"], shape=GRID, test_sets=[TestSet("none", np.zeros((0, GRID.size)))])


def test_evaluate_with_noise_is_seeded():
    sets = [TestSet("cc", natural_test_sets(GRID)[0].reflectances[:5])]
    a = evaluate(["Nikon 5100 (NPL)"], methods=["Prior"], shape=GRID, test_sets=sets, noise=0.002)
    b = evaluate(["Nikon 5100 (NPL)"], methods=["Prior"], shape=GRID, test_sets=sets, noise=0.002)
    assert a.rows[0].mean == b.rows[0].mean


def test_infeasible_noisy_responses_are_reported():
    sets = [TestSet("dark", np.full((6, GRID.size), 0.01))]
    ev = evaluate(["Nikon 5100 (NPL)"], methods=["least squares"], shape=GRID, test_sets=sets, noise=0.05)
    assert any("outside the camera's object-colour solid" in n for n in ev.notes)


def test_natural_sets_from_shared_data(shared_data):
    sets = natural_test_sets(GRID, data_dir=shared_data, size=20)
    names = " ".join(s.name for s in sets)
    for expected in ("Munsell", "Krinov", "Vrhel", "CIE 224"):
        assert expected in names
    for s in sets:
        assert s.reflectances.shape[1] == GRID.size and 0 <= s.reflectances.min() <= s.reflectances.max() <= 1


def test_structured_generator_seeded_valid_and_independent():
    from zonotope.spectra.atypical import STRUCTURED_KINDS, structured_reflectances

    A, labels = structured_reflectances(GRID, 60, seed=3)
    assert np.array_equal(A, structured_reflectances(GRID, 60, seed=3)[0])
    assert A.shape == (60, GRID.size) and A.min() >= 0 and A.max() <= 1
    assert {lab.rsplit(" ", 1)[0] for lab in labels} == set(STRUCTURED_KINDS)
    steps = A[[lab.startswith("steps") for lab in labels]]
    assert all(np.unique(s).size <= 2 for s in steps)  # two levels only
    with pytest.raises(SpectralDataError, match="steps"):
        structured_reflectances(GRID, 2, kinds=["ramp"])
    from zonotope.evaluate import atypical_test_sets

    a, b = atypical_test_sets(GRID, 10)
    assert (a.name, b.name) == ("atypical (10)", "atypical B (10)") and a.kind == b.kind == "atypical"
    # independent families: no spectrum of one set is within 0.05 of one of the other everywhere
    d = np.abs(a.reflectances[:, None] - b.reflectances[None]).max(-1)
    assert d.min() > 0.05


def test_source_split_removes_near_training_spectra():
    from zonotope.evaluate import source_split

    rng = np.random.default_rng(0)
    train = rng.uniform(0, 1, (30, GRID.size))
    near = np.clip(train[:5] + rng.uniform(-0.019, 0.019, (5, GRID.size)), 0, 1)
    far = train[5:10].copy()
    far[:, 3] = np.where(far[:, 3] > 0.5, far[:, 3] - 0.05, far[:, 3] + 0.05)  # one band 0.05 away
    sets = [TestSet("mixed", np.vstack([near, far])), TestSet("all near", near)]
    kept, notes = source_split(sets, train, exclude_within=0.02)
    assert [s.name for s in kept] == ["mixed"] and np.array_equal(kept[0].reflectances, far)
    assert any("5 of 10 spectra removed" in n for n in notes)
    # brute force: every kept spectrum is farther than 0.02 from every training one
    for x in kept[0].reflectances:
        assert all(np.abs(x - t).max() > 0.02 for t in train)
    assert source_split(sets, train, exclude_within=None)[0] == sets


def test_pooled_and_paired_statistics_from_samples():
    nat = natural_test_sets(GRID)
    sets = [nat[0], nat[1], TestSet("atyp", atypical_reflectances(GRID, 8, seed=2)[0], "atypical")]
    ev = evaluate(
        ["Nikon 5100 (NPL)"],
        methods=["least squares", "root-polynomial"],
        shape=GRID,
        test_sets=sets,
        noise=0,
    )
    assert any("spectra removed" in n for n in ev.notes)  # ColorChecker patches are in rawtoaces 190
    cams = ev.rows[0].cameras
    e_ls = np.concatenate([ev.errors[k] for k in ev.errors if k[2] == "Cheung 2004" and k[1] != "atyp"])
    n, mean, p95, mx = ev.pooled_stats("natural", cams)["Cheung 2004"]
    assert n == e_ls.size < 24 + 14 and mean == pytest.approx(e_ls.mean()) and mx == e_ls.max()
    assert p95 == pytest.approx(np.percentile(e_ls, 95))
    e_rp = np.concatenate([ev.errors[k] for k in ev.errors if k[2] == "Finlayson 2015" and k[1] != "atyp"])
    p = ev.paired("Cheung 2004", "Finlayson 2015", kind="natural", cameras=cams)
    q = ev.paired("Finlayson 2015", "Cheung 2004", kind="natural", cameras=cams)
    assert p.n == e_ls.size and p.mean_diff == pytest.approx((e_ls - e_rp).mean())
    assert p.a_better == pytest.approx(np.mean(e_ls < e_rp - 0.01)) and p.a_better == q.b_better
    assert p.max_diff == pytest.approx(-q.min_diff)
    assert ev.paired("Cheung 2004", "Cheung 2004").mean_diff == 0.0
    with pytest.raises(SpectralDataError, match="MAP"):
        ev.paired("Cheung 2004", "MAP")
    assert "pooled mean" in ev.to_markdown()


def test_evaluate_with_an_executor_equals_serial():
    from concurrent.futures import ThreadPoolExecutor

    sets = [TestSet("cc", natural_test_sets(GRID)[2].reflectances[:4])]
    kw = dict(methods=["Centroid", "Prior"], shape=GRID, test_sets=sets, noise=0)
    serial = evaluate(["Nikon 5100 (NPL)"], **kw)
    with ThreadPoolExecutor(2) as pool:
        par = evaluate(["Nikon 5100 (NPL)"], executor=pool, **kw)
    for key, e in serial.errors.items():
        np.testing.assert_array_equal(par.errors[key], e)
    assert serial.volumes == par.volumes
    prior = next(r for r in serial.rows if r.method == "Prior")
    assert prior.radius > 0 and 0 <= prior.coverage <= 1  # the uncertainty columns
    assert "covered" in serial.to_markdown()


@pytest.fixture
def recorders(monkeypatch):
    """Two dummy estimators ("Dummy A", "Dummy B": least-squares matrices with ``noise_option="noise"``)
    registered for one test; yields ``{name: {"fits": [options], "seen": [responses]}}``."""
    from zonotope.correct import CORRECTION_METHODS, fit_Cheung2004

    monkeypatch.setattr(CORRECTION_METHODS, "_methods", dict(CORRECTION_METHODS._methods))
    monkeypatch.setattr(CORRECTION_METHODS, "_keys", dict(CORRECTION_METHODS._keys))
    log: dict = {}
    for name in ("Dummy A", "Dummy B"):
        log[name] = {"fits": [], "seen": []}

        def fit(problem, _name=name, **options):
            log[_name]["fits"].append(dict(options))
            fitted = fit_Cheung2004(problem, **options)

            def predict(C, _predict=fitted.predict):
                log[_name]["seen"].append(np.array(C, dtype=np.float64))
                return _predict(C)

            return type(fitted)(_name, problem, predict, fitted.params)

        CORRECTION_METHODS.register(
            name, fit, closed_form=True, needs_mmv=False, centroid=False, noise_option="noise"
        )
    return log


def test_noise_levels_fit_every_method_for_its_noise_on_paired_draws(recorders):
    from zonotope.correct import NoiseModel, correction_problem
    from zonotope.evaluate import DEFAULT_NOISE

    sets = [TestSet("cqs", natural_test_sets(GRID)[2].reflectances[:6])]
    ev = evaluate(["Nikon 5100 (NPL)"], methods=["Dummy A", "Dummy B"], shape=GRID, test_sets=sets)
    assert ev.noise_levels == ["0", "shot σw 0.002", "shot σw 0.005"] and len(DEFAULT_NOISE) == 3
    assert [(r.noise, r.method) for r in ev.rows] == [
        (z, m) for z in ev.noise_levels for m in ("Dummy A", "Dummy B")
    ]
    # each method fitted once per level, for that level's noise model (σ at white per channel)
    fits = recorders["Dummy A"]["fits"]
    assert fits[0] == {} and all(isinstance(f["noise"], NoiseModel) for f in fits[1:])
    assert [f["noise"].sigma_white.tolist() for f in fits[1:]] == [[0.002] * 3, [0.005] * 3]
    # paired: both methods see the same responses at every level; the levels share the draws
    seen_a, seen_b = recorders["Dummy A"]["seen"], recorders["Dummy B"]["seen"]
    assert len(seen_a) == 3 and all(np.array_equal(a, b) for a, b in zip(seen_a, seen_b, strict=True))
    C0 = correction_problem("Nikon 5100 (NPL)", shape=GRID).source_of(sets[0].reflectances)
    np.testing.assert_array_equal(seen_a[0], C0)  # the noise-free level: exact responses
    z = [(C - C0) / (s * np.sqrt(np.maximum(C0, 0))) for C, s in zip(seen_a[1:], (0.002, 0.005), strict=True)]
    np.testing.assert_allclose(z[0], z[1], rtol=1e-9)
    assert 0.3 < np.std(z[0]) < 3  # standard normal draws, scaled by the level's σ per response
    # the noise is part of the result: errors keyed by level, seeded, noisier is worse on average
    again = evaluate(["Nikon 5100 (NPL)"], methods=["Dummy A"], shape=GRID, test_sets=sets)
    for key, e in again.errors.items():
        np.testing.assert_array_equal(ev.errors[key], e)
    means = [ev.pooled_stats("natural", noise=z)["Dummy A"][1] for z in ev.noise_levels]
    assert means[0] < means[2]
    assert ev.paired("Dummy A", "Dummy B", noise="shot σw 0.005").mean_diff == 0.0
    md = ev.to_markdown()
    assert "| cameras | test set | noise | estimator |" in md and "| shot σw 0.005 | Dummy A |" in md
    assert "| cameras | test set | kind | noise | Dummy A | Dummy B |" in ev.noise_markdown()


def test_noise_levels_given_as_sigma_model_or_mapping_and_bad_ones():
    from zonotope._errors import OptionError
    from zonotope.correct import NoiseModel, NoiseModelError
    from zonotope.evaluate import EvaluationConfig, noise_label

    cfg = EvaluationConfig(noise=[0, 0.003, {"shot": 2.5e-5, "read": 0.0}, NoiseModel(1e-5, 1e-6)])
    assert [noise_label(z) for z in cfg.noise] == ["0", "σ 0.003", "shot σw 0.005", "1e-05:1e-06"]
    assert EvaluationConfig(noise=0.01).noise == (0.01,)
    for bad, error in (("loud", OptionError), ([], OptionError), ([0.01, 0.01], OptionError)):
        with pytest.raises(error, match="noise"):
            EvaluationConfig(noise=bad)
    for bad in (-0.01, float("nan"), {"shot": -1.0, "read": 0.0}):
        with pytest.raises(NoiseModelError, match=r"EvaluationConfig\.noise"):
            EvaluationConfig(noise=bad)


def test_cli_grid_over_the_cap_is_a_one_line_error_before_any_work(capsys):
    """``--interval 0.001`` used to build test sets on 300,001 wavelengths until a MemoryError."""
    import resource

    from zonotope.cli import main

    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    assert main(["evaluate", "--camera", "Nikon 5100 (NPL)", "--interval", "0.001"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "GRID_POINTS_MAX" in err and "interval" in err, err
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200_000  # KiB: nothing built


def test_cli_camera_in_micrometres_is_a_one_line_error(tmp_path, capsys):
    from zonotope.cli import main

    w = np.arange(400, 701, 10)
    path = tmp_path / "cam_um.csv"
    lines = ["wavelength,r,g,b"]
    for x in w:
        r, g, b = (np.exp(-(((x - c) / 40) ** 2)) for c in (600, 540, 460))
        lines.append(f"{x / 1000:.3f},{r:.4f},{g:.4f},{b:.4f}")
    path.write_text("\n".join(lines) + "\n")
    assert main(["evaluate", "--camera", str(path), "--atypical", "0"]) == 2
    err = capsys.readouterr().err.strip()
    # the loader names the file (zonotope.spectra.loading), evaluate the option: either is one line
    assert err.count("\n") == 0 and ("--camera" in err or str(path) in err) and "µm" in err, err


def test_library_test_sets_refuse_an_oversized_grid():
    from zonotope.evaluate import atypical_test_set

    w = np.linspace(400, 700, 300_001)
    for build in (lambda: natural_test_sets(w), lambda: atypical_test_set(w, 3)):
        with pytest.raises(SpectralDataError, match="GRID_POINTS_MAX"):
            build()
