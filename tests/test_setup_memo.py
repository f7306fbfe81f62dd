"""Functions built once per process and problem: the digest of what defines them, the memo, one vehicle
per set of parameters, and controllers and filters of one problem sharing their functions (issue 39:
per-run set-up)."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from auvdock.config.mission import load_mission
from auvdock.loop.simulation import run_simulation
from auvdock.runtime.fingerprint import Memo, digest
from auvdock.vehicle.vehicle import load_vehicle


def test_digest_tells_values_and_kinds_apart() -> None:
    assert digest(1, "a", np.arange(3.0)) == digest(1, "a", np.arange(3.0))
    different = [
        digest(1),
        digest(1.0),
        digest("1"),
        digest([1]),
        digest(np.array([1])),
        digest(np.array([1.0])),
        digest(np.array([[1.0]])),
        digest({"a": 1}),
        digest({"a": 2}),
        digest(None),
        digest(True),
    ]
    assert len(set(different)) == len(different)
    assert digest({"a": 1, "b": 2}) == digest({"b": 2, "a": 1})
    # a vehicle's parameters (a frozen dataclass of arrays) and a mission's settings (pydantic)
    m = load_mission("tank_0p6hz")
    assert digest(m.vehicle_params()) == digest(load_mission("tank_0p8hz").vehicle_params())
    assert digest(m.navigation) != digest(m.navigation.model_copy(update={"substeps": 2}))


def test_digest_refuses_what_it_cannot_see_into() -> None:
    with pytest.raises(
        TypeError, match=r"^cannot fingerprint an object of type function \(give what defines it instead\)$"
    ):
        digest(1, lambda x: x)
    with pytest.raises(
        TypeError, match=r"^cannot fingerprint an object of type object \(give what defines it instead\)$"
    ):
        digest(object())


def test_a_memo_builds_once_per_thread_and_keeps_at_most_its_size() -> None:
    memo = Memo(size=2)
    built: list[int] = []

    def make(v: int):
        def build() -> list[int]:
            built.append(v)
            return [v]

        return build

    a = memo.get("x", (1,), make(1))
    assert memo.get("x", (1,), make(1)) is a and built == [1]
    assert memo.get("y", (1,), make(2)) is not a  # another name, another thing
    other: list = []
    t = threading.Thread(target=lambda: other.append(memo.get("x", (1,), make(3))))
    t.start()
    t.join()
    assert other[0] is not a and built == [1, 2, 3]  # built again in another thread
    # at most 2 kept: the least recently used ("x" of this thread) went first
    memo.get("z", (1,), make(4))
    memo.get("x", (1,), make(5))
    assert built == [1, 2, 3, 4, 5] and (memo.hits, memo.misses) == (1, 5)
    # what its keeper refuses is built every time
    memo.get("w", (1,), make(6), keep=lambda: False)
    memo.get("w", (1,), make(7), keep=lambda: False)
    assert built[-2:] == [6, 7]


def test_functions_are_not_kept_while_their_compile_runs_in_the_background(monkeypatch) -> None:
    """AUVDOCK_COMPILE=auto on a cold cache runs uncompiled while a detached process compiles: a sweep's
    later runs must load the compiled library once it is there, so nothing is kept meanwhile."""
    from auvdock.runtime import codegen

    class Running:
        def poll(self) -> None:
            return None

    vehicle = load_mission("still").build_vehicle()
    calls: list[int] = []
    monkeypatch.setattr(codegen, "_background", [Running()])
    vehicle.built("probe", (1,), lambda: calls.append(1))
    vehicle.built("probe", (1,), lambda: calls.append(2))
    assert calls == [1, 2]
    monkeypatch.setattr(codegen, "_background", [])
    vehicle.built("probe", (1,), lambda: calls.append(3))
    vehicle.built("probe", (1,), lambda: calls.append(4))
    assert calls == [1, 2, 3]


def test_one_vehicle_per_set_of_parameters() -> None:
    a = load_mission("tank_0p6hz").build_vehicle()
    assert load_mission("diagonal").build_vehicle() is a  # the same Heavy
    assert load_vehicle("bluerov2_heavy") is a
    heavier = load_mission("tank_0p6hz").with_updates(**{"vehicle.overrides": {"mass_kg": 12.0}})
    assert heavier.build_vehicle() is not a
    assert load_vehicle("bluerov2") is not a


@pytest.mark.parametrize("controller", ["oracle", "optimized"])
def test_runs_of_one_problem_share_its_functions_and_fly_as_if_built_anew(controller: str) -> None:
    """The second run's controller and filters take the functions the first built (no build: the
    vehicle's memo counts hits only) and its outcome is the same bits as a run built from nothing."""
    m = load_mission("diagonal_camera")
    vehicle = m.build_vehicle()
    first = run_simulation(m.with_updates(seed=3), controller=controller, timeout_s=0.5, keep=True)
    misses = vehicle._built.misses
    again = run_simulation(m.with_updates(seed=3), controller=controller, timeout_s=0.5, keep=True)
    assert vehicle._built.misses == misses and vehicle._built.hits > 0
    vehicle._built.clear()
    fresh = run_simulation(m.with_updates(seed=3), controller=controller, timeout_s=0.5, keep=True)
    for r in (again, fresh):
        assert r.run is not None and first.run is not None
        np.testing.assert_array_equal(r.run.thrust_N, first.run.thrust_N)
        np.testing.assert_array_equal(r.run.state, first.run.state)
    # another horizon is another problem: built for it
    longer = m.with_updates(**{"controller.horizon_steps": 12})
    run_simulation(longer, controller=controller, timeout_s=0.1)
    assert vehicle._built.misses > misses
