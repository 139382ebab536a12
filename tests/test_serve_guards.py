"""The planning service as a robot stack and a hostile client meet it (issue 22).

* it never answers with a non-finite action, one outside the task's bounds, or one beyond
  ``REACH_MARGIN`` times the one-step reach (a property over random and adversarial states);
* hostile requests get 422 with one ``error`` line naming the exact field, never echoing a long value;
* ``scdp serve`` exits 2 before listening on a broken model set or an unresolvable host.
"""

import json
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest
from fastapi.testclient import TestClient

from helpers.stubs import StubPlanner
from scdp.config import PlannerSpec
from scdp.errors import ScdpError
from scdp.serve.app import MAX_BODY_BYTES, PlanningService, create_app
from scdp.serve.batcher import BatchingOptions
from scdp.tasks import NAVIGATION, REACH_MARGIN

ACT = {"state_history": [[0.0, 0.0, 0.0]], "goals": [[2.0, 0.3], [2.0, -0.3]], "target": 0, "method": "dp", "seed": 3}
LOW, HIGH = NAVIGATION.state_bounds()
STEP = 0.22 * NAVIGATION.control_dt  # the TurtleBot's one-step reach in metres
ERROR_LINE = re.compile(r"^scdp: error: (?P<field>[^:]+): (?P<problem>.+)$")


@pytest.fixture(scope="module")
def checkpoints(tiny_reproduction):
    return tiny_reproduction / "navigation" / "checkpoints"


@pytest.fixture(scope="module")
def service(checkpoints):
    return PlanningService(checkpoints, "navigation", batching=BatchingOptions(max_wait_ms=1.0))


@pytest.fixture(scope="module")
def client(service):
    with TestClient(create_app(service)) as c:
        yield c


def field_of(response) -> str:
    error = response.json()["error"]
    assert "\n" not in error and len(error) < 400, error
    return error.split(":")[0]


def post(client, body, path="/v1/act"):
    if isinstance(body, (str, bytes)):
        return client.post(path, content=body, headers={"content-type": "application/json"})
    return client.post(path, json=body)


# -- the property: nothing non-finite, outside the bounds or out of reach ever comes back ----------------
def adversarial_states() -> list:
    rng = np.random.default_rng(22)
    states = [[1e308, 1e308, 0.0], [-1e308, 0.0, 0.0], [100.0, 100.0, 0.0], [0.0, 0.0, 1e6], [0.0, 0.0, -1e300],
              "NaN", "Infinity", [5e-324, -5e-324, 0.0]]
    for j in range(3):  # just inside and just outside every bound
        for edge, sign in ((LOW, 1.0), (HIGH, -1.0)):
            for nudge in (1e-9, -1e-9):
                s = [0.0, 0.0, 0.0]
                s[j] = float(edge[j] + sign * nudge)
                states.append(s)
    states += [rng.uniform(LOW, HIGH).tolist() for _ in range(16)]
    states += [rng.uniform(-1e3, 1e3, 3).tolist() for _ in range(8)]
    states += [(np.array([2.0, 0.0, 0.0]) + rng.normal(0, 0.3, 3)).tolist() for _ in range(8)]  # near the goals
    return states


def inside(state) -> bool:
    s = np.asarray(state, dtype=float)
    return bool(np.all(np.isfinite(s)) and np.all((s >= LOW) & (s <= HIGH)))


def test_the_service_never_returns_a_non_finite_or_out_of_reach_action(client):
    for k, state in enumerate(adversarial_states()):
        method = ("dp", "ld", "scdp")[k % 3]
        if isinstance(state, str):  # NaN and inf are not JSON numbers, but Python's parser reads them
            body = json.dumps({**ACT, "method": method}).replace("[[0.0, 0.0, 0.0]]", f"[[{state}, 0.0, 0.0]]")
            state = [float(state.replace("Infinity", "inf")), 0.0, 0.0]
        else:
            body = {**ACT, "method": method, "state_history": [state], "seed": k}
        response = post(client, body)
        if response.status_code == 200:
            actions = np.asarray(response.json()["actions"], dtype=float)
            previous = np.vstack([state, actions[:-1]])
            assert inside(state), state  # a state outside the bounds is never planned from
            assert actions.shape == (len(actions), 3) and np.all(np.isfinite(actions)), (state, actions)
            assert np.all((actions >= LOW) & (actions <= HIGH)), (state, actions)
            assert NAVIGATION.reach_used(previous, actions).max() <= REACH_MARGIN, (state, actions)
        else:
            assert response.status_code == 422, response.text
            assert field_of(response) == ("actions" if inside(state) else "state_history"), (state, response.text)


def ahead(state, per_step):  # 4 actions driving straight along x, ``per_step`` reaches each
    return np.array([state + [per_step * STEP * (k + 1), 0.0, 0.0] for k in range(4)])


@pytest.mark.parametrize("make", [
    lambda s: np.full((4, 3), np.nan),
    lambda s: np.full((4, 3), np.inf),
    lambda s: ahead(s, 2 * REACH_MARGIN),  # every step twice the margin
    lambda s: np.vstack([ahead(s, 0.5)[:3], [[s[0] + 9.0, s[1], s[2]]]]),  # one far jump at the end
    lambda s: np.array([s, s, s, [s[0], s[1], s[2] + 3.0]]),  # a 3 rad turn in one step
    lambda s: np.array([[s[0], HIGH[1] + 0.01, s[2]]] * 4),  # outside the room
], ids=["nan", "inf", "too fast", "far jump", "spin", "outside"])
def test_a_chunk_that_fails_the_last_check_is_refused_not_clamped(client, service, monkeypatch, make):
    monkeypatch.setitem(service.planners, PlannerSpec.of("dp"), StubPlanner(make))
    state = [0.0, HIGH[1] - 0.005, 0.0]
    response = post(client, {**ACT, "state_history": [state]})
    assert response.status_code == 422 and field_of(response) == "actions", response.text
    assert client.get("/v1/health").status_code == 200


def test_a_chunk_within_reach_comes_back_unchanged(client, service, monkeypatch):
    monkeypatch.setitem(service.planners, PlannerSpec.of("dp"), StubPlanner(lambda s: ahead(s, 0.9 * REACH_MARGIN)))
    response = post(client, {**ACT, "state_history": [[0.5, 0.25, 0.0]]})  # exact in float32
    assert response.status_code == 200, response.text
    assert response.json()["actions"] == ahead(np.array([0.5, 0.25, 0.0]), 0.9 * REACH_MARGIN).tolist()
    assert response.json()["style"] == "none" and response.json()["batch_size"] == 1 and response.json()["method"] == "dp"


def test_plan_refuses_a_trajectory_with_an_out_of_reach_action(client, service, monkeypatch):
    monkeypatch.setitem(service.planners, PlannerSpec.of("dp"), StubPlanner(lambda s: ahead(s, 3.0)))
    response = post(client, {"goals": ACT["goals"], "method": "dp"}, "/v1/plan")
    assert response.status_code == 422 and field_of(response) == "actions", response.text


def test_scenes_of_different_goal_counts_are_planned_in_one_group(service):
    scenes = [([[2.0, 0.3], [2.0, -0.3]], 0), ([[2.0, 0.3], [2.0, -0.3], [2.5, 0.0]], 2)]
    items = [{"history": np.zeros((1, 3)), "goals": np.asarray(g), "target": t, "seed": 1} for g, t in scenes]
    results = service._act_group((PlannerSpec.of("dp"), 0, 8), items)
    assert len(results) == 2 and all(isinstance(r, (dict, ScdpError)) for r in results)
    assert all(r.field == "actions" for r in results if isinstance(r, ScdpError))


# -- hostile requests, each refused on its exact field --------------------------------------------------
HUGE = "x" * 1_000_000
REQUESTS = [
    ({**ACT, "state_history": [[1e308, 1e308, 0.0]]}, "state_history"),
    ({**ACT, "state_history": [[100.0, 100.0, 0.0]]}, "state_history"),
    ({**ACT, "state_history": [[100.0, 100.0, 0.0], [0.0, 0.0, 0.0]]}, "state_history"),  # every entry, not the last
    ({**ACT, "state_history": [[0.0, 0.0, 1e6]]}, "state_history"),
    ({**ACT, "state_history": [[float(HIGH[0]) + 1e-6, 0.0, 0.0]]}, "state_history"),
    ('{"state_history": [[NaN, 0, 0]], "goals": [[2, 0.3], [2, -0.3]]}', "state_history"),
    ({**ACT, "goals": [[1e308, 0.3], [2.0, -0.3]]}, "goals"),
    ({**ACT, "target": "1"}, "target"),
    ({**ACT, "target": True}, "target"),
    ({**ACT, "target": 1.0}, "target"),
    ({**ACT, "seed": "3"}, "seed"),
    ({**ACT, "goals": [["2", 0.3], [2.0, -0.3]]}, "goals"),
    ({**ACT, "method": "dp", "style": "legible"}, "style"),
    ({**ACT, "method": "ld", "style": "auto"}, "style"),
    ({**ACT, "method": "scdp_paper", "style": "legible"}, "style"),  # the paper's design has no style choice
    ({**ACT, "method": "magic"}, "method"),
    ({**ACT, "method": "scdp_legible", "style": "efficient"}, "style"),
    ({**ACT, "method": "scdp", "goals": [[2.0, 0.3], [2.0, -0.3], [2.5, 0.0]]}, "goals"),  # the encoder reads 2 goals
    ({**ACT, "method": HUGE}, "method"),
    ({**ACT, "style": HUGE}, "style"),
    ({**ACT, "velocity": 3}, "velocity"),
    ({**ACT, HUGE: 3}, "body"),  # a key too long to be a field name is named inside the problem, cut short
    ("{not json", "body"),
    ('{"state_history": [[0, 0, 0]], "goals": [[2, 0.3], [2, -0.3]]', "body"),
    ("[" * 100_000 + "]" * 100_000, "body"),
    ('{"state_history": ' + "[" * 500 + "]" * 500 + ', "goals": [[2, 0.3], [2, -0.3]]}', "state_history"),
    ('{"state_history": [[0, 0, 0]], "goals": [[2, 0.3], [2, -0.3]], "seed": ' + "9" * 5000 + "}", "body"),
    ("[1, 2]", "body"),
]


@pytest.mark.parametrize("body, field", REQUESTS, ids=range(len(REQUESTS)))
def test_hostile_requests_are_refused_on_their_exact_field(client, body, field):
    response = post(client, body)
    assert response.status_code == 422 and set(response.json()) == {"error"}, response.text[:300]
    assert field_of(response) == field, response.json()["error"]
    assert HUGE[:200] not in response.text  # never more than a short prefix of a bad value
    assert not re.search(r"\(char \d+\)|line \d+ column \d+", response.text)  # no character offsets


@pytest.mark.parametrize("body, field", [
    ({"goals": ACT["goals"], "method": "dp", "style": "efficient"}, "style"),
    ({"goals": ACT["goals"], "target": "0"}, "target"),
    ({"goals": ACT["goals"], "method": "scdp_efficient", "style": "legible"}, "style"),
])
def test_plan_requests_are_checked_the_same_way(client, body, field):
    response = post(client, body, "/v1/plan")
    assert response.status_code == 422 and field_of(response) == field, response.text


def test_a_style_equal_to_the_one_a_method_fixes_is_accepted(client):
    response = post(client, {**ACT, "method": "scdp_legible", "style": "legible"})
    assert response.status_code == 200 or field_of(response) == "actions", response.text


def test_unknown_paths_and_http_methods_use_the_error_form(client):
    assert client.get("/v1/nowhere").json() == {"error": "path: Not Found"}
    response = client.get("/v1/act")
    assert response.status_code == 405 and field_of(response) == "http_method"


# -- broken model sets are refused before listening ---------------------------------------------------------
def broken(checkpoints, tmp_path, damage):
    folder = tmp_path / "ckpt"
    shutil.copytree(checkpoints, folder)
    damage(folder)
    return folder


def truncate_base(folder):
    path = folder / "base" / "model.safetensors"
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


def paper_half(folder):  # one of scdp_paper's predictors left: scdp_paper is still served, so the other is missing
    shutil.rmtree(folder / "style_paper_efficient")


BROKEN = [
    ("truncated base", truncate_base, None, "checkpoints/base"),
    ("no style_legible", lambda f: shutil.rmtree(f / "style_legible"), None, "checkpoints/style_legible"),
    ("no ld, ld served", lambda f: shutil.rmtree(f / "ld"), None, "checkpoints/ld"),
    ("no ld, ld_paper served", lambda f: shutil.rmtree(f / "ld"), ["dp", "ld_paper"], "checkpoints/ld"),
    ("no encoder, scdp_none served", lambda f: shutil.rmtree(f / "encoder"), ["scdp_none"], "checkpoints/encoder"),
    ("half of scdp_paper", paper_half, None, "checkpoints/style_paper_efficient"),
    ("a method twice", lambda f: None, ["dp", "dp"], "--methods"),
]


@pytest.mark.parametrize("damage, methods, field", [b[1:] for b in BROKEN], ids=[b[0] for b in BROKEN])
def test_a_broken_model_set_is_refused_at_construction(checkpoints, tmp_path, damage, methods, field):
    with pytest.raises(ScdpError) as err:
        PlanningService(broken(checkpoints, tmp_path, damage), "navigation", methods=methods)
    assert err.value.field == field


def test_a_model_set_without_ld_serves_the_methods_that_do_not_need_it(checkpoints, tmp_path):
    service = PlanningService(broken(checkpoints, tmp_path, lambda f: shutil.rmtree(f / "ld")), "navigation",
                              methods=["dp", "scdp"])
    assert service.methods == ("dp", "scdp") and service.info()["methods"] == ["dp", "scdp"]


def test_scdp_paper_is_served_only_where_its_predictors_are(checkpoints, tmp_path):
    assert (checkpoints / "style_paper_legible").is_dir()  # the tiny set holds both paper-design predictors
    assert "scdp_paper" in PlanningService(checkpoints, "navigation").methods

    def neither(folder):
        for part in ("style_paper_legible", "style_paper_efficient"):
            shutil.rmtree(folder / part)

    service = PlanningService(broken(checkpoints, tmp_path, neither), "navigation")
    assert "scdp_paper" not in service.methods and "scdp" in service.methods


SERVE_FAILURES = [
    ("truncated base", truncate_base, [], "checkpoints/base"),
    ("no style_legible", lambda f: shutil.rmtree(f / "style_legible"), [], "checkpoints/style_legible"),
    ("no ld", lambda f: shutil.rmtree(f / "ld"), [], "checkpoints/ld"),
    ("unresolvable host", lambda f: None, ["--host", "no-such-host.invalid"], "--host"),
]


@pytest.mark.parametrize("damage, extra, field", [c[1:] for c in SERVE_FAILURES], ids=[c[0] for c in SERVE_FAILURES])
def test_scdp_serve_exits_2_before_listening(checkpoints, tmp_path, damage, extra, field):
    folder = broken(checkpoints, tmp_path, damage)
    done = subprocess.run([sys.executable, "-m", "scdp", "serve", "--task", "navigation", "--checkpoints", str(folder),
                           "--port", "0", "--device", "cpu", *extra], capture_output=True, text=True, timeout=180)
    assert done.returncode == 2, (done.stdout[-300:], done.stderr[-300:])
    assert "serving" not in done.stdout
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and ERROR_LINE.match(lines[0])["field"] == field, done.stderr[-500:]


def test_a_body_over_the_cap_is_refused_before_it_is_read(client):
    big = b'{"states": [' + b"0," * (MAX_BODY_BYTES // 2) + b'0]}'
    r = client.post("/v1/act", content=big, headers={"content-type": "application/json"})
    assert r.status_code == 413 and r.json()["error"].startswith("body: larger than the")
