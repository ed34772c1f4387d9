"""Several robots (MODEL.md section 10) in the core: the ``robots`` instance form, fleet plans and
the simulator's rules between robots, each checked against the independent oracle of
tests/oracles/model_oracle.py."""

from __future__ import annotations

import copy
import json
import random

import pytest
from conftest import case_study as _case_study  # noqa: F401  (the fixture)
from conftest import field_instances, fleet_instances
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles import model_oracle as oracle

import voiopt
from voiopt.core.instance import from_dict
from voiopt.core.plan import FleetPlan, Plan
from voiopt.errors import InstanceError, PlanError

CASES = fleet_instances()


def test_cases_make_the_rules_between_robots_bind():
    """Dropping robot 1 (so robot 0 plans alone) changes the oracle's legal plan count in
    every case: the shared fixture is worth testing on."""
    assert len(CASES) >= 10
    for inst in CASES:
        assert inst.n_robots == 2 and inst.fleet
        assert oracle.count_legal_plans(inst.to_dict()) > 0


@pytest.mark.parametrize("inst", CASES, ids=lambda i: i.name)
def test_random_legal_fleet_plans_evaluate_to_the_oracle(inst):
    d = inst.to_dict()
    rng = random.Random(inst.name)
    for _ in range(25):
        plan = oracle.random_legal_plan(d, rng)
        got = voiopt.evaluate(inst, Plan.from_dict(plan))
        want = oracle.simulate(d, plan)
        for ob in oracle.OBJECTIVES:
            assert got[ob] == pytest.approx(want[ob], rel=1e-12, abs=1e-300), (ob, plan)


def test_fleet_instance_round_trips():
    for inst in CASES:
        again = from_dict(json.loads(json.dumps(inst.to_dict())))
        assert again == inst
        assert "start" not in inst.to_dict() and len(inst.to_dict()["robots"]) == 2


def test_one_robot_instance_accepts_both_forms_with_the_same_metrics(case_study):
    """The one-entry robots form is the same instance and the same plan as the flat form."""
    d = case_study.to_dict()
    robots = copy.deepcopy(d)
    robots["robots"] = [{"start": robots.pop("start")}]
    assert from_dict(robots) == case_study
    plan = voiopt.load_plan(voiopt.core.instance.Path(__file__).parent.parent / "instances" / "case-study.plan.json")
    wrapped = Plan.from_dict({"robots": [plan.to_dict()]})
    assert wrapped == plan
    assert voiopt.evaluate(case_study, wrapped) == voiopt.evaluate(case_study, plan)
    for inst in field_instances(6):
        flat = inst.to_dict()
        form = {k: v for k, v in flat.items() if k not in ("start", "end", "max_moves")}
        form["robots"] = [{k: flat[k] for k in ("start", "end", "max_moves") if k in flat}]
        assert from_dict(form) == inst


def _legal(inst):
    return oracle.random_legal_plan(inst.to_dict(), random.Random(1))


def _with(plan, k, t, **change):
    out = copy.deepcopy(plan)
    for key, v in change.items():
        out["robots"][k][key][t] = v
    return out


def _two_robots(T=3, **extra):
    """A 3 x 1 corridor: robots at either end, one sensor in the middle."""
    d = {"area": {"width": 2, "height": 0.0001}, "step": 1, "horizon": T,
         "robots": [{"start": [0, 0]}, {"start": [2, 0]}], "channel": {"d_th": 1.0},
         "sensors": [{"position": [1, 0], "rho": 0.5}]}
    d.update(extra)
    return d


@pytest.mark.parametrize("rule, plan, message", [
    ("vertex", {"robots": [{"positions": [[0, 0], [1, 0], [1, 0]], "schedule": [0, None, None]},
                           {"positions": [[2, 0], [1, 0], [2, 0]], "schedule": [None, None, None]}]},
     "robots[1].positions[1]: [1, 0] is also robot 0's point in slot 1"),
    ("swap", {"robots": [{"positions": [[0, 0], [1, 0], [2, 0]], "schedule": [None, None, None]},
                         {"positions": [[2, 0], [2, 0], [1, 0]], "schedule": [None, None, None]}]},
     "robots[1].positions[2]: robots 0 and 1 swap points"),
    ("upload twice", {"robots": [{"positions": [[0, 0], [0, 0], [0, 0]], "schedule": [0, None, None]},
                                 {"positions": [[2, 0], [2, 0], [2, 0]], "schedule": [0, None, None]}]},
     "robots[1].schedule[0]: sensor 0 also uploads to robot 0 in slot 0"),
    ("end", {"robots": [{"positions": [[0, 0], [0, 0], [0, 0]], "schedule": [None, None, None]},
                        {"positions": [[2, 0], [2, 0], [2, 0]], "schedule": [None, None, None]}]},
     "robots[0].positions[2]: must equal end [1, 0]"),
    ("count", {"robots": [{"positions": [[0, 0], [0, 0], [0, 0]], "schedule": [None, None, None]}]},
     "the instance has 2 robots"),
])
def test_rules_between_robots_reject_with_the_robot_slot_and_rule(rule, plan, message, tmp_path):
    d = _two_robots()
    if rule == "end":
        d["robots"][0]["end"] = [1, 0]
    inst = from_dict(d)
    with pytest.raises(oracle.OracleError):
        oracle.simulate(d, plan)
    with pytest.raises(PlanError, match=message.replace("[", r"\[").replace("]", r"\]")):
        voiopt.evaluate(inst, Plan.from_dict(plan))
    # and on the command line: one line, exit 2
    (tmp_path / "i.json").write_text(json.dumps(d))
    (tmp_path / "p.json").write_text(json.dumps(plan))
    from voiopt.cli.main import main
    assert main(["evaluate", str(tmp_path / "i.json"), str(tmp_path / "p.json")]) == 2


def test_each_swap_and_shared_point_the_oracle_rejects_voiopt_rejects():
    """Mutations of legal plans (moving one robot onto the other's next or current point):
    voiopt rejects exactly the plans the oracle rejects."""
    rng = random.Random(5)
    checked = 0
    for inst in CASES:
        d = inst.to_dict()
        for _ in range(20):
            plan = oracle.random_legal_plan(d, rng)
            k, t = rng.randrange(2), rng.randrange(inst.horizon)
            bad = _with(plan, k, t, positions=plan["robots"][1 - k]["positions"][max(0, t - rng.randint(0, 1))])
            bad = _with(bad, k, t, schedule=rng.choice([None, *range(inst.n_sensors)]))
            try:
                want = oracle.simulate(d, bad)
            except oracle.OracleError:
                want = None
            if want is None:
                with pytest.raises(PlanError):
                    voiopt.evaluate(inst, Plan.from_dict(bad))
            else:
                assert voiopt.evaluate(inst, Plan.from_dict(bad))["mean-min-voi"] == pytest.approx(want["mean-min-voi"])
            checked += 1
    assert checked >= 200


@pytest.mark.parametrize("change, message", [
    ({"robots": [{"start": [0, 0]}, {"start": [0, 0]}]}, "robots[1].start: [0, 0] is also robots[0].start"),
    ({"robots": [{"start": [0, 0], "end": [1, 0]}, {"start": [2, 0], "end": [1, 0]}]},
     "robots[1].end: [1, 0] is also robots[0].end"),
    ({"start": [0, 0]}, "start: must not be given with robots"),
    ({"max_moves": 2}, "max_moves: must not be given at the top level with robots"),
    ({"robots": []}, "robots: must be a list of 1 to 64 robots"),
    ({"robots": [{"start": [0, 0], "speed": 2}]}, "robots[0].speed: unknown field"),
    ({"robots": [{"start": [0, 0]}, {"end": [1, 0]}]}, "robots[1].start: is required"),
    ({"robots": [{"start": [0, 0]}, {"start": [2, 0], "end": [0, 0], "max_moves": 1}]},
     "robots[1].end: [0, 0] is not reachable within 1 move "),
    ({"robots": [{"start": [0, 0]}, {"start": [2, 0]}], "blocked": [[2, 0]]}, "blocked[0]: [2, 0] is robots[1].start"),
])
def test_fleet_instance_errors_name_the_robot(change, message):
    d = _two_robots()
    d.update(change)
    with pytest.raises(InstanceError) as e:
        from_dict(d)
    assert str(e.value).startswith(message), str(e.value)
    with pytest.raises(oracle.OracleError):
        oracle.check_instance(d)


def test_a_fleet_that_cannot_finish_together_is_rejected_in_one_line(tmp_path, capsys):
    """MODEL.md section 9: an instance that admits no legal plan is rejected by validation. In
    this corridor each robot alone can reach the other's start, but they cannot pass each other
    (the oracle finds no legal plan); with a second lane they can."""
    from voiopt.cli.main import main

    wide = {"area": {"width": 2, "height": 1}, "step": 1, "horizon": 6,
            "robots": [{"start": [0, 0], "end": [2, 0]}, {"start": [2, 0], "end": [0, 0]}],
            "sensors": [{"position": [1, 0.5], "rho": 0.5}]}
    narrow = {**wide, "blocked": [[0, 1], [1, 1], [2, 1]]}
    assert next(oracle.legal_plans(wide), None) is not None and next(oracle.legal_plans(narrow), None) is None
    assert from_dict(wide).n_robots == 2
    with pytest.raises(InstanceError, match=r"^robots: no legal joint plan: each robot can reach its end alone"):
        from_dict(narrow)
    for d, code in ((wide, 0), (narrow, 2)):
        path = tmp_path / "fleet.json"
        path.write_text(json.dumps(d))
        assert main(["validate", str(path)]) == code
        err = capsys.readouterr().err.strip()
        assert (err == "") if code == 0 else (err.count("\n") == 0 and "robots[0]: [0, 0] to [2, 0]" in err), err


def test_single_robot_methods_refuse_a_fleet_in_one_line():
    inst = CASES[0]
    with pytest.raises(voiopt.OptionError, match="plans for one robot, but the instance has 2 robots"):
        voiopt.solve(inst, "beam")


def test_fleet_plan_json_round_trips():
    for inst in CASES[:4]:
        plan = Plan.from_dict(_legal(inst))
        assert isinstance(plan, FleetPlan) and len(plan.robots) == 2
        assert Plan.from_dict(json.loads(json.dumps(plan.to_dict()))) == plan


def test_the_joint_moves_are_built_in_chunks_that_a_stop_interrupts(monkeypatch):
    """``joint._moves_of`` (every joint move from every joint point) took 1.6 s for four robots,
    in one kernel call that no limit could stop (a fuzz campaign: fleet Q-learning ended at
    2.05 s for a 0.5 s limit). It is now built CHUNK joint points at a time with the stop rule
    checked between chunks; a stopped build caches nothing, and the chunks give exactly the
    joint moves a plain enumeration of MODEL.md section 10's rules gives."""
    import itertools

    import numpy as np

    from voiopt.grid import joint, paths
    from voiopt.runtime.stop import Stop, Stopped

    nb = paths.neighbors(3, 2, np.array([False, False, True, False, False, False]))  # 3 x 2 points, one blocked
    n, K = nb.shape[0], 3
    monkeypatch.setattr(joint, "_MOVES", type(joint._MOVES)())
    monkeypatch.setattr(joint, "CHUNK", 5)  # n**K = 216 joint points: 44 chunks
    chunks = []
    kernel = joint._joint_moves
    monkeypatch.setattr(joint, "_joint_moves", lambda *a: chunks.append(a[-2]) or kernel(*a))
    stop = Stop()
    check = Stop.check
    monkeypatch.setattr(Stop, "check", lambda self, *a: (len(chunks) == 3 and self.request(), check(self, *a))[1])
    with pytest.raises(Stopped):  # stopped between chunks: after the third, before the fourth
        joint._moves_of(nb.tobytes(), n, K, stop)
    assert chunks == [0, 5, 10] and not joint._MOVES
    monkeypatch.setattr(Stop, "check", check)
    configs, nxt_cfg, moved = joint._moves_of(nb.tobytes(), n, K, Stop())
    for c, cfg in enumerate(itertools.product(range(n), repeat=K)):
        assert tuple(configs[c]) == cfg
        for mv, dirs in enumerate(itertools.product(range(5), repeat=K)):
            nxt = [int(nb[p, d]) for p, d in zip(cfg, dirs, strict=True)]
            legal = (min(nxt) >= 0 and len(set(cfg)) == K and len(set(nxt)) == K
                     and not any(nxt[a] == cfg[b] and nxt[b] == cfg[a] for a in range(K) for b in range(K) if a != b))
            want = sum(q * n ** (K - 1 - k) for k, q in enumerate(nxt)) if legal else -1
            assert nxt_cfg[c, mv] == want, (cfg, dirs)
            assert [bool(x) for x in moved[c, mv]] == [q != p for p, q in zip(cfg, nxt, strict=True)]


def _alive_by_brute_force(nx, ny, blocked, ends, budgets, horizon):
    """{(t, points, moves made): alive} by plain recursion over every joint move (MODEL.md
    sections 9 and 10), for robots on distinct points with moves made within their budgets
    (None: no budget, moves not counted)."""
    import functools
    import itertools

    free = [(k, l) for k in range(nx) for l in range(ny) if (k, l) not in blocked]
    index = {(k, l): k * ny + l for k, l in free}

    def steps(p):
        k, l = p
        return [q for q in [(k, l), (k + 1, l), (k - 1, l), (k, l + 1), (k, l - 1)] if q in index]

    @functools.cache
    def alive(t, pts, made):
        if t == horizon - 1:
            return all(e is None or p == e for p, e in zip(pts, ends, strict=True))
        for nxt in itertools.product(*[steps(p) for p in pts]):
            if len(set(nxt)) < len(nxt) or any(nxt[a] == pts[b] and nxt[b] == pts[a]
                                               for a in range(len(pts)) for b in range(a)):
                continue
            m2 = tuple(m + (q != p) if b is not None else 0 for m, q, p, b in zip(made, nxt, pts, budgets, strict=True))
            if all(b is None or m <= b for m, b in zip(m2, budgets, strict=True)) and alive(t + 1, nxt, m2):
                return True
        return False

    out = {}
    for pts in itertools.permutations(free, len(ends)):
        for made in itertools.product(*[range(b + 1) if b is not None else [0] for b in budgets]):
            for t in range(horizon):
                out[t, tuple(index[p] for p in pts), made] = alive(t, pts, made)
    return out


@settings(max_examples=40, deadline=None)
@given(st.data())
def test_the_alive_table_matches_brute_force_in_every_slot(data):
    """The table of joint states that can still keep every rule, read slot by slot through
    ``row`` (it stores only the slots after the last one equal to its successor), is exactly
    the plain recursion over joint moves, for two and three robots with ends, budgets and
    blocked points."""
    import numpy as np

    from voiopt.grid import joint, paths

    K = data.draw(st.sampled_from([2, 2, 3]))
    nx, ny = data.draw(st.integers(1, 3)), data.draw(st.integers(2, 3))
    cells = [(k, l) for k in range(nx) for l in range(ny)]
    blocked = data.draw(st.sets(st.sampled_from(cells), max_size=2))
    free = [c for c in cells if c not in blocked]
    if len(free) < K:
        return
    ends = [data.draw(st.one_of(st.none(), st.sampled_from(free))) for _ in range(K)]
    ends = [e if e not in ends[:k] else None for k, e in enumerate(ends)]  # distinct ends
    T = data.draw(st.integers(1, 9 if K == 2 else 6))
    budgets = [data.draw(st.one_of(st.none(), st.integers(0, 4 if K == 2 else 2))) for _ in range(K)]
    mask = np.zeros(nx * ny, dtype=bool)
    for k, l in blocked:
        mask[k * ny + l] = True
    tab = joint.table(paths.neighbors(nx, ny, mask), [-1 if e is None else e[0] * ny + e[1] for e in ends], budgets, T)
    bud, counted, radix = joint.budgets(budgets, T)
    want = _alive_by_brute_force(nx, ny, blocked, ends, [int(b) if c else None for b, c in zip(bud, counted, strict=True)], T)
    for (t, pts, made), alive in want.items():
        c = m = 0
        for k in range(K):  # robot 0 most significant
            c, m = c * nx * ny + pts[k], m * radix[k] + made[k]
        assert bool(tab.row(t)[c, m]) == alive, (t, pts, made)


def test_the_alive_table_stores_only_the_slots_that_differ(monkeypatch):
    """Every slot before the last one equal to its successor is a copy of it (staying is a legal
    joint move), and is not stored: three robots with budgets at T = 589 once held 3.2 GB of
    copies, 6.9 s to write. The memory limit counts the slots stored as they are built."""
    import numpy as np

    from voiopt.grid import joint, paths
    from voiopt.runtime.stop import MEMORY_LIMIT, Stop, Stopped

    nb = paths.neighbors(3, 3, np.zeros(9, dtype=bool))
    args = (nb, [0, 8, 2], [3, None, 4], 600)
    tab = joint.table(*args)
    assert tab.first > 0 and len(tab.alive) + tab.first == 600 and len(tab.alive) < 20
    assert not (tab.row(tab.first) == tab.row(tab.first + 1)).all()  # no stored slot repeats its successor
    path = joint.walk(tab, [6, 4, 1])  # a legal plan through the stored slots
    assert path.shape == (3, 600) and list(path[:, -1][:2]) == [0, 8]
    with pytest.raises(Stopped) as e:  # a limit smaller than the stored slots stops the build
        joint.table(*args, stop=Stop(memory_limit=(tab.configs.nbytes + tab.nxt_cfg.nbytes + tab.moved.nbytes
                                                   + 2.5 * tab.alive[0].nbytes) / 1e9))
    assert e.value.args == (MEMORY_LIMIT,)
