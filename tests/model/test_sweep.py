"""The blocked sweep against the whole-array prediction, and its bounded memory.

``sweep`` must give ``predict`` + ``rank``'s rows whatever its blocks (the only
difference allowed is the rounding of a matrix product summed in another
order: relative 1e-12 here, observed ≤ 1.5e-13 for ε), and its memory must not
grow with the number of combinations.
"""

import json
import tracemalloc

import numpy as np
import pytest
from conftest import run_cli as run

from inspect_validate.components import Optics, SensorModel, builtin_sensor, led
from inspect_validate.errors import InputError
from inspect_validate.model import ObjectClass, predict, rank, sweep
from inspect_validate.model.sweep import _blocks
from inspect_validate.spectra import Spectrum

GRID = np.arange(380.0, 781.0, 2.0)
RTOL = 1e-12
ROW_FIELDS = ("exposure_time", "mean", "variance", "snr_db", "cnr_db", "error_gaussian")


def station(n_l, n_o, n_c, *, seed=0, blind=True, n_classes=3):
    """Random LEDs, lenses and cameras over 380–780 nm; a SWIR camera, blind there, last."""
    rng = np.random.default_rng(seed)
    lights = [
        led(rng.uniform(420, 740), rng.uniform(10, 60), name=f"L{i}", irradiance=1.0)
        for i in range(n_l)
    ]
    optics = [
        Optics(
            f"O{i}",
            Spectrum(
                GRID,
                0.6 + 0.35 * np.sin(GRID / rng.uniform(60, 200) + rng.uniform(0, 6)) ** 2,
                "transmission",
                f"O{i}",
                "test",
            ),
            rng.uniform(2, 8),
        )
        for i in range(n_o)
    ]
    cameras = [
        SensorModel(
            f"C{i}",
            Spectrum(
                GRID,
                0.7 * np.exp(-0.5 * ((GRID - rng.uniform(450, 700)) / rng.uniform(60, 200)) ** 2),
                "qe",
                f"C{i}",
                "test",
            ),
            0.4,
            2.5,
            10000,
            12,
        )
        for i in range(n_c - blind)
    ]
    if blind:
        cameras.append(builtin_sensor("ingaas-swir"))
    classes = []
    for k in range(n_classes):
        base = 0.4 + 0.2 * np.sin(GRID / (90 + 30 * k)) ** 2
        samples = base * (1 + rng.normal(0, 0.02, (8, 1))) + rng.normal(0, 0.003, (8, GRID.size))
        classes.append(
            ObjectClass(f"K{k}", Spectrum(GRID, samples, "reflectance", f"K{k}", "test"))
        )
    return lights, optics, cameras, classes


@pytest.mark.parametrize(
    ("by", "comparison"),
    [("error", None), ("snr_db", None), ("error", "K0 vs K1,K2"), ("cnr_db", "K1 vs K2")],
)
@pytest.mark.parametrize("memory", [10**9, 300_000, 20_000])
def test_sweep_gives_predict_and_rank_rows_whatever_the_blocks(by, comparison, memory):
    parts = station(6, 5, 7)
    p = predict(*parts, grid=GRID)
    order, key, column, saturated = rank(p, by=by, comparison=comparison)
    r = sweep(*parts, grid=GRID, by=by, comparison=comparison, top=9, memory=memory)
    assert r.blocks > 1 or memory == 10**9
    assert r.index.tolist() == order[:9].tolist()
    assert r.worst == tuple(order[-1])
    np.testing.assert_allclose(r.key, key[:9], rtol=RTOL, atol=0)
    assert r.column.tolist() == column[:9].tolist()
    assert r.saturated.tolist() == saturated[:9].tolist()
    rows = tuple(order[:9].T)
    for name in ROW_FIELDS:  # every comparison, the group ε computed afterwards included
        np.testing.assert_allclose(
            getattr(r, name), getattr(p, name)[rows], rtol=RTOL, atol=0, err_msg=name
        )
    np.testing.assert_allclose(r.sample_mean, p.sample_mean[rows], rtol=RTOL, atol=0)
    # The SWIR camera, blind under most LEDs: skipped in both, for the same reasons.
    assert 6 * 5 * 6 <= r.predicted == int(p.valid.sum()) < 6 * 5 * 7
    assert r.skipped == p.skipped if r.blocks == 1 else set(r.skipped) == set(p.skipped)


def test_group_errors_are_computed_for_the_listed_rows_only_and_say_so():
    parts = station(4, 3, 4, blind=False)
    r = sweep(*parts, grid=GRID, top=5)
    groups = [j for j, (a, b) in enumerate(r.comparisons) if len(a) > 1 or len(b) > 1]
    assert len(groups) == 3 and np.isfinite(r.error_gaussian[:, groups]).all()
    (note,) = r.skipped_work
    assert "for the 5 rows listed only, not for 43 other combinations: 129 root searches" in note
    by_group = sweep(*parts, grid=GRID, top=5, comparison="K0 vs K1,K2")
    (note,) = by_group.skipped_work  # the ranked group is computed everywhere
    assert "K0 vs K1,K2" not in note and "86 root searches" in note
    everything = sweep(*parts, grid=GRID, top=48)  # every row listed: nothing skipped
    assert everything.skipped_work == ()


def test_sweep_memory_does_not_grow_with_the_combinations():
    """tracemalloc sees numpy's buffers: the peak stays near the block budget while
    predict's grows with the sweep (two classes: no mixture ε to wait for)."""
    budget = 2 * 2**20
    peaks = {}
    for n_l in (32, 128):
        parts = station(n_l, 8, 8, blind=False, n_classes=2)
        for name, call in (
            ("sweep", lambda parts=parts: sweep(*parts, grid=GRID, top=10, memory=budget)),
            ("predict", lambda parts=parts: predict(*parts, grid=GRID)),
        ):
            tracemalloc.start()
            call()
            peaks[name, n_l] = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
    assert peaks["predict", 128] > 3 * peaks["predict", 32]  # grows with the combinations
    assert peaks["sweep", 128] < 1.3 * peaks["sweep", 32]  # the inputs grow
    assert peaks["sweep", 128] < 1.5 * budget


def test_blocks_split_the_largest_axis_last():
    parts = station(3, 4, 5, blind=False)
    from inspect_validate.model.acquisition import Exposure, prepare

    chain = prepare(*parts, exposure=Exposure(), grid=GRID, comparisons=None)
    whole = list(_blocks(chain, memory=10**9))
    assert whole == [(slice(0, 3), slice(0, 4), slice(0, 5))]
    tiny = list(_blocks(chain, memory=1))  # one combination a block, every one once
    assert len(tiny) == 60
    covered = {
        (li, oi, ci)
        for ls, os, cs in tiny
        for li in range(3)[ls]
        for oi in range(4)[os]
        for ci in range(5)[cs]
    }
    assert len(covered) == 60


def test_a_sweep_where_nothing_can_be_predicted_names_why():
    _, optics, _, classes = station(2, 2, 1, blind=False)
    lights = [led(450, 20, name="blue"), led(520, 20, name="green")]
    with pytest.raises(InputError, match="no combination of the scene can be predicted"):
        sweep(lights, optics, [builtin_sensor("ingaas-swir")], classes, grid=GRID, memory=1)


def test_cli_lists_what_the_ranking_did_not_compute(tmp_path, capsys):
    g = np.arange(380, 781, 5)
    for name, level in (("a", 0.3), ("b", 0.6), ("c", 0.45)):
        rows = "\n".join(f"{w},{level},{level * 1.02},{level * 0.98}" for w in g)
        (tmp_path / f"{name}.csv").write_text(rows + "\n")
    leds = ", ".join(f"{{led: {{peak: {p}, fwhm: 30}}, name: L{p}}}" for p in range(420, 720, 20))
    (tmp_path / "s.yaml").write_text(
        "classes: {A: {file: a.csv}, B: {file: b.csv}, C: {file: c.csv}}\n"
        f"lights: [{leds}]\noptics: [ideal]\ncameras: [cmos-visible, ingaas-swir]\n"
    )
    out = tmp_path / "p.json"
    assert run(["predict", tmp_path / "s.yaml", "--top", "3", "--json", out, "--kde", "never"]) == 0
    err = capsys.readouterr().err
    assert "not computed: ε Gauss of A vs B,C, B vs A,C, C vs A,B" in err
    assert "for the 3 rows listed only, not for 12 other combinations: 36 root searches" in err
    doc = json.loads(out.read_text())
    assert doc["combinations"] == 30 and len(doc["ranking"]) == 3
    assert doc["skipped_work"] and len(doc["skipped"]) == 15  # the SWIR camera under each
    for row in doc["ranking"]:
        assert all(0 <= c["error_gaussian"] <= 0.5 for c in row["comparisons"])


@pytest.fixture(scope="module")
def dask_cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, dashboard_address=":0"
    ) as cluster:
        yield cluster


def test_sweep_on_a_dask_cluster_equals_the_sweep_in_process(dask_cluster):
    """Two worker processes: the chain pickled to each, blocks merged in completion order;
    every row the same to the bit, the same skipped reasons in block order."""
    from distributed import Client

    parts = station(6, 5, 7)
    here = sweep(*parts, grid=GRID, top=9, memory=20_000, comparison="K0 vs K1,K2")
    with Client(dask_cluster) as client:
        there = sweep(
            *parts, grid=GRID, top=9, memory=20_000, comparison="K0 vs K1,K2", client=client
        )
    assert there.blocks == here.blocks > 10
    assert there.index.tolist() == here.index.tolist() and there.worst == here.worst
    assert there.skipped == here.skipped and there.predicted == here.predicted
    for name in (*ROW_FIELDS, "sample_mean", "sample_variance", "key"):
        np.testing.assert_array_equal(getattr(there, name), getattr(here, name), err_msg=name)


@pytest.mark.slow
def test_cli_predict_on_dask_by_address_and_locally(tmp_path, capsys, dask_cluster):
    g = np.arange(380, 781, 5)
    for name, level in (("a", 0.3), ("b", 0.6)):
        rows = "\n".join(f"{w},{level},{level * 1.02},{level * 0.98}" for w in g)
        (tmp_path / f"{name}.csv").write_text(rows + "\n")
    leds = ", ".join(f"{{led: {{peak: {p}, fwhm: 30}}, name: L{p}}}" for p in range(420, 720, 20))
    scene = tmp_path / "s.yaml"
    scene.write_text(
        "classes: {A: {file: a.csv}, B: {file: b.csv}}\n"
        f"lights: [{leds}]\noptics: [ideal]\ncameras: [cmos-visible, cmos-nir-enhanced]\n"
    )
    docs = {}
    for label, extra in (
        ("here", []),
        ("address", [f"--dask={dask_cluster.scheduler_address}"]),
        ("local", ["--dask"]),
    ):
        out = tmp_path / f"{label}.json"
        assert run(["predict", scene, "--json", out, "--kde", "never", *extra]) == 0, label
        docs[label] = json.loads(out.read_text())
    assert docs["address"]["ranking"] == docs["here"]["ranking"] == docs["local"]["ranking"]
    capsys.readouterr()
    code = run(["predict", scene, "--dask=tcp://127.0.0.1:9"])  # nothing listens on port 9
    assert code == 3
    assert "dask scheduler tcp://127.0.0.1:9: cannot connect" in capsys.readouterr().err
