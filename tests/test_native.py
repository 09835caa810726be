"""The compiled SUMO reader (acc_fusion.truth.sumo.native): built from the installed SUMO wheels,
the same
values as libsumo's Python functions, and a clean fallback where it cannot be built."""

from __future__ import annotations

import shutil
import sys
import warnings

import numpy as np
import pytest

libsumo = pytest.importorskip("libsumo")

import acc_fusion.truth.sumo.native as native  # noqa: E402
from acc_fusion.truth.sumo.config import SumoConfig  # noqa: E402
from acc_fusion.truth.sumo.nets import bundled_nets  # noqa: E402
from acc_fusion.truth.sumo.source import SumoSource  # noqa: E402

BUILDS_HERE = sys.platform.startswith("linux") and bool(shutil.which("c++") or shutil.which("g++"))


@pytest.fixture
def fresh(monkeypatch, tmp_path):
    """An empty cache, and ``sumo_reader`` forgetting what it built or decided before."""
    monkeypatch.setenv("ACC_FUSION_CACHE", str(tmp_path / "cache"))
    native.sumo_reader.cache_clear()
    yield tmp_path / "cache"
    native.sumo_reader.cache_clear()


def frames(cfg: SumoConfig) -> list[np.ndarray]:
    """Every step's frame arrays and slot ids."""
    out = []
    with SumoSource(cfg) as src:
        assert (src._native is not None) == cfg.native
        while True:
            f = src.frame()
            rows = [f.ego_speed, f.ego_accel, f.gap, f.lead_speed, f.lead_accel, f.leader_id]
            out.append((np.stack(rows), src.vehicle_ids))
            if src.done:
                return out
            src.advance()


@pytest.mark.skipif(not BUILDS_HERE, reason="the compiled reader is built on Linux with c++")
def test_it_builds_here_and_gives_libsumos_values_bit_for_bit():
    """On the on-ramp (merges, unequipped leaders at 60 % penetration, hazards): every frame
    read by the compiled reader equals the one read through libsumo's Python functions."""
    assert native.sumo_reader() is not None  # CI would otherwise only test the fallback
    net = str(bundled_nets()["onramp"])
    kw = dict(end=120.0, seed=3, penetration=0.6, hazard_rate=50.0)
    fast, slow = (frames(SumoConfig(net, native=flag, **kw)) for flag in (True, False))
    assert len(fast) == len(slow) == 1201
    for (a, ids_a), (b, ids_b) in zip(fast, slow, strict=True):
        np.testing.assert_array_equal(a, b)  # NaN where NaN, else the same bits
        assert ids_a == ids_b
    leaders = np.stack([a[5] for a, _ in fast])
    assert (leaders >= 0).sum() > 10_000  # the comparison saw many pairs with a leader


@pytest.mark.skipif(not BUILDS_HERE, reason="the compiled reader is built on Linux with c++")
def test_it_is_compiled_once_into_the_cache_and_raises_libsumos_error(fresh):
    reader = native.sumo_reader()
    built = list(fresh.iterdir())
    assert reader is not None and len(built) == 1 and built[0].name.startswith("_sumo_reads-")
    stamp = built[0].stat().st_mtime_ns
    native.sumo_reader.cache_clear()
    assert native.sumo_reader() is not None and built[0].stat().st_mtime_ns == stamp
    with SumoSource(SumoConfig(str(bundled_nets()["ring"]), end=2.0)):
        speed, dist, code = np.empty(1), np.empty(1), np.empty(1, dtype=np.int64)
        codes, slot = reader.Codes(), np.zeros(1, dtype=np.int64)
        with pytest.raises(libsumo.TraCIException):
            reader.read(["no such vehicle"], slot, 100.0, codes, 4, speed, dist, code)
        with pytest.raises(ValueError, match="8-byte buffers"):
            reader.read(["x", "y"], slot, 100.0, codes, 4, speed, dist, code)
        with pytest.raises(ValueError, match=r"slots in \[0, n_pairs\)"):
            reader.read(["x"], slot + 4, 100.0, codes, 4, speed, dist, code)
        with pytest.raises(ValueError, match=r"slots in \[0, n_pairs\)"):
            reader.read([], slot, 100.0, codes, -1, speed, dist, code)
        with pytest.raises(TypeError):
            reader.read(["x"], slot, 100.0, {}, 4, speed, dist, code)  # a dict is not its table


@pytest.mark.skipif(not BUILDS_HERE, reason="the compiled reader is built on Linux with c++")
def test_its_code_table_behaves_as_the_dict_it_replaces():
    codes, plain = native.sumo_reader().Codes(), {}
    for table in (codes, plain):
        table["car.1"], table["truck.22"], table["car.1"] = 3, 7, 5
        del table["truck.22"]
        table["bus"] = 9
    assert len(codes) == len(plain) == 2 and codes["car.1"] == plain["car.1"] == 5
    assert "bus" in codes and "truck.22" not in codes
    assert codes.get("bus") == 9 and codes.get("nobody") is None and codes.get("nobody", -1) == -1
    assert codes.pop("bus") == 9 and codes.pop("bus", None) is None and len(codes) == 1
    with pytest.raises(KeyError, match="truck.22"):
        codes["truck.22"]
    with pytest.raises(KeyError, match="nobody"):
        del codes["nobody"]
    with pytest.raises(TypeError):
        codes[3] = 1  # ids are strings
    # Deleted keys are erased in bulk once they outnumber the live ones (and 1024): the table
    # stays a dict throughout.
    del plain["bus"]
    for i in range(3000):
        for table in (codes, plain):
            table[f"v{i}"] = i
            if i % 3:
                del table[f"v{i}"]
    assert len(codes) == len(plain) == 1001 and all(codes[k] == v for k, v in plain.items())
    assert "v2999" not in codes and codes.get("v2998") is None and codes["v2997"] == 2997


@pytest.mark.skipif(not BUILDS_HERE, reason="the compiled reader is built on Linux with c++")
def test_a_slot_keeps_its_leaders_entry_through_changes_and_erasures_of_the_table():
    """read() remembers, per slot, where its last leader's code is in the table: the codes it
    gives follow every change of the table, a key deleted and set again, and the bulk erasure
    of deleted keys, as a lookup in a dict would."""
    reader = native.sumo_reader()
    with SumoSource(SumoConfig(str(bundled_nets()["ring"]), end=10.0, native=False)) as src:
        for _ in range(50):
            src.advance()
        vids = list(libsumo.vehicle.getIDList())
        n = len(vids)
        leaders = [libsumo.vehicle.getLeader(v, 250.0) for v in vids]
        assert sum(lead is not None for lead in leaders) >= n // 2
        codes, plain = reader.Codes(), {}
        slots = np.arange(n, dtype=np.int64)[::-1].copy()  # any slot for any vehicle
        speed, dist, code = np.empty(n), np.empty(n), np.empty(n, dtype=np.int64)

        def check() -> None:
            reader.read(vids, slots, 250.0, codes, n, speed, dist, code)
            want = [plain.get(lead[0], -1) if lead else -1 for lead in leaders]
            assert code.tolist() == want

        for k, vid in enumerate(vids):
            codes[vid] = plain[vid] = (k + 1) * (n + 1) + 1
        check()  # the slots find and keep their leaders' entries
        a, b = [lead[0] for lead in leaders if lead][:2]  # two leaders, kept by their slots
        for k, vid in enumerate(vids[::2]):
            codes[vid] = plain[vid] = (k + 7) * (n + 1) + 2
        del codes[a], plain[a]
        check()  # changed in place, one deleted
        codes[a] = plain[a] = 5 * (n + 1) + 3
        check()  # set again
        del codes[b], plain[b]
        for i in range(2000):  # enough deletions to erase the deleted keys, b's among them
            codes[f"gone.{i}"] = 1
            del codes[f"gone.{i}"]
        check()
        codes[b] = plain[b] = 9 * (n + 1) + 4  # a new entry
        check()


def test_without_a_compiler_it_warns_once_and_the_source_reads_through_libsumo(fresh, monkeypatch):
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setenv("CXX", "false")  # a "compiler" that always fails
    with pytest.warns(RuntimeWarning, match=r"not available \(false failed"):
        assert native.sumo_reader() is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert native.sumo_reader() is None  # decided once per process
        with SumoSource(SumoConfig(str(bundled_nets()["ring"]), end=2.0)) as src:
            assert src._native is None
            while not src.done:
                src.advance()
    assert not fresh.exists() or not any(fresh.iterdir())  # nothing half-written


def test_it_can_be_switched_off_without_a_warning(fresh, monkeypatch):
    monkeypatch.setenv("ACC_FUSION_NATIVE", "0")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert native.sumo_reader() is None
    with pytest.raises(Exception, match="native must be true or false"):
        SumoConfig("x.sumocfg", native="yes")


def test_other_platforms_and_mismatched_wheels_fall_back_with_the_reason(fresh, monkeypatch):
    monkeypatch.setattr(sys, "platform", "darwin")
    with pytest.warns(RuntimeWarning, match="built on Linux only, this is darwin"):
        assert native.sumo_reader() is None
    native.sumo_reader.cache_clear()
    monkeypatch.setattr(sys, "platform", "linux")
    real = native.importlib.metadata.version
    monkeypatch.setattr(
        native.importlib.metadata,
        "version",
        lambda name: "0.0.1" if name == "eclipse-sumo" else real(name),
    )
    with pytest.warns(RuntimeWarning, match=r"libsumo \S+ and eclipse-sumo 0.0.1 differ"):
        assert native.sumo_reader() is None
