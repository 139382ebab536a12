"""The planning service: endpoints, one-line errors, dynamic batching and refusal under overload."""

import asyncio
import threading

import numpy as np
import pytest
from fastapi.testclient import TestClient

from scdp.config import PlannerSpec, PlanningOptions
from scdp.content import file_sha256
from scdp.evaluation import records
from scdp.scoring import Bounds
from scdp.serve.app import PlanningService, create_app
from scdp.serve.batcher import BatchingOptions, Busy, DynamicBatcher

ACT = {"state_history": [[0.0, 0.0, 0.0]], "goals": [[2.0, 0.3], [2.0, -0.3]], "target": 0, "method": "scdp", "seed": 3}


@pytest.fixture(scope="module")
def service(tiny_reproduction):
    return PlanningService(tiny_reproduction / "navigation" / "checkpoints", "navigation", batching=BatchingOptions(max_wait_ms=1.0))


@pytest.fixture(scope="module")
def client(service):
    with TestClient(create_app(service)) as c:
        yield c


def test_health_info_and_schema(client, tiny_reproduction):
    health = client.get("/v1/health").json()
    assert health["status"] == "ok"
    folder = tiny_reproduction / "navigation" / "checkpoints"
    for part in ("base", "ld", "encoder", "style_legible", "style_efficient", "style_paper_legible"):  # every served planner's
        assert health["parts"][part] == {"weights_sha256": file_sha256(folder / part / "model.safetensors"), "runtime": "torch"}
    info = client.get("/v1/info").json()
    assert info["task"] == "navigation" and info["preset"] == "tiny" and info["device"] == "cpu"
    assert "scdp" in info["methods"] and info["state_dim"] == 3 and info["parts"] == health["parts"]
    paths = client.get("/openapi.json").json()["paths"]
    assert {"/v1/act", "/v1/plan", "/v1/health", "/v1/info"} <= set(paths)


def test_the_sampler_can_be_replaced_and_a_bad_one_is_refused_at_start(tiny_reproduction):
    from scdp.errors import ScdpError

    folder = tiny_reproduction / "navigation" / "checkpoints"
    replaced = PlanningService(folder, "navigation", planning=PlanningOptions(sampler="ddpm", steps=3))
    info = replaced.info()
    assert (info["sampler"], info["inference_steps"]) == ("ddpm", 3)
    assert replaced.planner(PlannerSpec.of("dp")).config.num_inference_steps == 3
    with pytest.raises(ScdpError, match="--steps"):
        PlanningService(folder, "navigation", planning=PlanningOptions(steps=1000))  # refused before serving, not at the first request


@pytest.mark.parametrize("method", ["dp", "ld", "scdp", "scdp_legible"])
def test_act_returns_a_seeded_chunk(client, service, method):
    """The tiny preset's barely trained nets plan chunks far beyond the robot's reach, which the service
    refuses (tests/test_serve_guards.py); the seeded chunk itself is checked where it is planned."""
    body = {**ACT, "method": method}
    first, again = client.post("/v1/act", json=body), client.post("/v1/act", json=body)
    if first.status_code == 200:
        a = np.asarray(first.json()["actions"])
        assert a.shape == (service.meta["config"]["n_action_steps"], 3) and np.all(np.isfinite(a))
        assert first.json()["server_ms"] > 0 and first.json()["actions"] == again.json()["actions"]
    else:
        assert first.status_code == 422 and first.json()["error"].startswith("actions: "), first.text
        assert again.json() == first.json()  # the same seed plans the same refused chunk
    key = PlannerSpec.parse(method)
    item = {"history": np.zeros((1, 3)), "goals": np.asarray(ACT["goals"]), "target": 0, "seed": 3}
    (a, answer, _), = service._plan_group((key, 0, 8), [item])
    (b, _, _), = service._plan_group((key, 0, 8), [item])
    (c, _, _), = service._plan_group((key, 0, 8), [{**item, "seed": 4}])
    style = answer["style"]
    assert a.shape == (service.meta["config"]["n_action_steps"], 3) and np.all(np.isfinite(a))
    assert style in ({"legible", "efficient"} if method.startswith("scdp") else {"none"})
    assert np.array_equal(a, b) and not np.array_equal(a, c)  # same seed, same chunk; another seed, another


def test_a_request_gets_the_same_chunk_alone_or_in_a_batch(service):
    items = [{"history": np.array([[0.0, 0.0, 0.0]]), "goals": np.array([[2.0, 0.3], [2.0, -0.3]]), "target": t, "seed": s}
             for t, s in ((0, 3), (1, 5), (0, 8))]
    together = service._plan_group((PlannerSpec.parse("scdp"), 0, 8), items)
    alone = service._plan_group((PlannerSpec.parse("scdp"), 0, 8), items[1:2])
    assert together[1][2] == 3 and alone[0][2] == 1  # batch sizes
    assert np.allclose(together[1][0], alone[0][0], atol=1e-5)


@pytest.mark.parametrize("body, field", [
    ({k: v for k, v in ACT.items() if k != "goals"}, "goals"),
    ({**ACT, "goals": [[2.0, 0.3]]}, "goals"),
    ({**ACT, "goals": [[2.0, 0.3], [2.0, 0.3]]}, "goals"),
    ({**ACT, "goals": [[2.0, 0.3], [2.0, 0.3, 1.0]]}, "goals"),
    ({**ACT, "goals": [[40.0, 0.3], [2.0, -0.3]]}, "goals"),
    ({**ACT, "goals": [[0.05, 0.0], [2.0, -0.3]]}, "goals"),
    ({**ACT, "goals": [["a", 0.3], [2.0, -0.3]]}, "goals"),
    ({**ACT, "target": 2}, "target"),
    ({**ACT, "target": -1}, "target"),
    ({**ACT, "state_history": []}, "state_history"),
    ({**ACT, "state_history": [[0.0, 0.0]]}, "state_history"),
    ('{"state_history": [[1e999, 0, 0]], "goals": [[2, 0.3], [2, -0.3]]}', "state_history"),  # overflows to inf
    ({**ACT, "method": "rrt"}, "method"),
    ({**ACT, "style": "flashy"}, "style"),
    ({**ACT, "seed": -1}, "seed"),
    ({**ACT, "chunk_index": -2}, "chunk_index"),
    ({**ACT, "velocity": 3}, "velocity"),
])
def test_malformed_requests_get_one_line_field_errors(client, body, field):
    response = (client.post("/v1/act", content=body, headers={"content-type": "application/json"}) if isinstance(body, str)
                else client.post("/v1/act", json=body))
    assert response.status_code == 422
    error = response.json()["error"]
    assert "\n" not in error and error.split(":")[0].startswith(field), error
    assert client.get("/v1/health").status_code == 200  # still serving


def test_a_body_that_is_not_json_is_refused(client):
    response = client.post("/v1/act", content=b"{not json", headers={"content-type": "application/json"})
    assert response.status_code == 422 and "\n" not in response.json()["error"]


BOUNDS = Bounds(0.0, 1.0, 0.0, 2.0)


def test_plan_runs_a_whole_trajectory(client, service, monkeypatch):
    """A planner that drives at half its reach towards the target (the tiny nets' plans are refused)."""
    import torch

    from scdp.policies.base import Chunk

    class Towards:
        n_obs_steps, n_action_steps, n_goals, style_modes, denoiser_parameters = 2, 4, None, (), 0

        def reset(self):
            pass

        def act(self, obs, generator=None):
            s, g = obs.state_hist[:, -1].double(), obs.goal.double()
            step = (g - s[:, :2]) / torch.linalg.norm(g - s[:, :2], dim=1, keepdim=True) * 0.022
            heading = torch.atan2(step[:, 1], step[:, 0])
            turn = heading[:, None] - s[:, 2:]
            chunk = [torch.cat([s[:, :2] + step * (k + 1), s[:, 2:] + turn * min(1, (k + 1) / 2)], 1) for k in range(4)]
            return Chunk(torch.stack(chunk, 1), ["none"] * len(s))

    monkeypatch.setitem(service.planners, PlannerSpec.of("dp"), Towards())
    response = client.post("/v1/plan", json={"goals": [[2.0, 0.3], [2.0, -0.3]], "method": "dp", "seed": 1})
    assert response.status_code == 200, response.text
    result = response.json()
    assert result["success"]
    assert len(result["path"]) >= 2 and len(result["actions"]) == len(result["path"]) - 1
    assert set(result["metrics"]) >= {"d_hat", "e_hat", "transparency"}
    assert client.post("/v1/plan", json={"goals": [[2.0, 0.3]]}).status_code == 422
    # the scene's reference bounds were computed once: the same scene again reads them from the memo
    computed = []
    monkeypatch.setattr(records.scoring, "reference_bounds", lambda *a, **k: computed.append(a) or BOUNDS)
    again = client.post("/v1/plan", json={"goals": [[2.0, 0.3], [2.0, -0.3]], "method": "dp", "seed": 1}).json()
    assert computed == [] and again["bounds"] == result["bounds"]
    other = client.post("/v1/plan", json={"goals": [[2.0, 0.4], [2.0, -0.3]], "method": "dp", "seed": 1}).json()
    assert len(computed) == 1 and other["bounds"] == BOUNDS.to_dict()


def test_the_bounds_memo_keeps_its_most_recent_scenes():
    memo = records.BoundedCache(2)
    memo["a"], memo["b"] = 1, 2
    assert memo["a"] == 1  # a is now the most recent
    memo["c"] = 3
    assert list(memo) == ["a", "c"]


def test_concurrent_requests_share_one_call():
    calls = []

    def run_group(key, items):
        calls.append((key, list(items)))
        return [item * 10 for item in items]

    async def scenario():
        batcher = DynamicBatcher(run_group, max_batch=64, max_wait_s=0.05)
        batcher.start()
        results = await asyncio.gather(*(batcher.submit("a" if i % 3 else "b", i) for i in range(12)))
        await batcher.stop()
        return results, batcher.stats

    results, stats = asyncio.run(scenario())
    assert results == [i * 10 for i in range(12)]
    assert sorted(len(items) for _, items in calls) == [4, 8]  # one call per key
    assert stats.calls == 2 and stats.requests == 12 and stats.largest_batch == 8


def test_a_lone_request_runs_at_once_and_a_crowd_waits_for_company(monkeypatch):
    """The worker waits max_wait_s for more requests only after a call that served several: a lone client's
    request never waits (the wait is read off the batcher's own decision, not a clock)."""
    waits = []
    real_wait_for = asyncio.wait_for

    async def wait_for(awaitable, timeout):
        waits.append(timeout)
        return await real_wait_for(awaitable, timeout)

    monkeypatch.setattr(asyncio, "wait_for", wait_for)

    async def scenario():
        batcher = DynamicBatcher(lambda key, items: list(items), max_batch=4, max_wait_s=30.0)
        batcher.start()
        alone = [await batcher.submit("k", i) for i in range(3)]  # one after another: never a companion
        waited_alone = list(waits)
        crowd = await asyncio.gather(*(batcher.submit("k", i) for i in range(4)))  # arrive together: one call
        after = [asyncio.ensure_future(batcher.submit("k", 9))]  # the next call waits for company ...
        while not waits[len(waited_alone):]:
            await asyncio.sleep(0)
        after += [asyncio.ensure_future(batcher.submit("k", i)) for i in (10, 11, 12)]  # ... and runs once full
        joined = await asyncio.gather(*after)
        await batcher.stop()
        return alone, waited_alone, crowd, joined, batcher.stats

    alone, waited_alone, crowd, joined, stats = asyncio.run(scenario())
    assert alone == [0, 1, 2] and waited_alone == [] and crowd == [0, 1, 2, 3] and joined == [9, 10, 11, 12]
    assert waits and waits[0] > 1.0  # after the crowd's call the worker waited (up to 30 s) for company
    assert stats.calls == 5 and stats.largest_batch == 4  # three lone calls, the crowd, the four that joined


def _blocked_batcher(**kw):
    """A batcher whose network call blocks until ``release`` is set; ``started`` is set once it runs."""
    started, release = threading.Event(), threading.Event()

    def blocked(key, items):
        started.set()
        release.wait(60)
        return items

    return DynamicBatcher(blocked, max_batch=1, max_wait_s=0.0, **kw), started, release


def test_a_full_queue_refuses_new_requests():
    async def scenario():
        batcher, started, release = _blocked_batcher(max_queue=2)
        batcher.start()
        first = asyncio.ensure_future(batcher.submit("k", 0))
        await asyncio.get_running_loop().run_in_executor(None, started.wait, 60)  # request 0 holds the planner
        waiting = [asyncio.ensure_future(batcher.submit("k", i)) for i in (1, 2)]
        await asyncio.sleep(0)  # let both reach the queue (no time passes: one turn of the event loop)
        with pytest.raises(Busy):
            await batcher.submit("k", 3)  # two are waiting: the third is refused at once
        release.set()
        results = await asyncio.gather(first, *waiting)
        await batcher.stop()
        return results, batcher.stats

    results, stats = asyncio.run(scenario())
    assert results == [0, 1, 2] and stats.refused == 1


def test_a_request_that_waited_past_the_timeout_is_refused():
    now = [0.0]  # the batcher's clock, moved by hand

    async def scenario():
        batcher, started, release = _blocked_batcher(max_queue=100, timeout_s=0.5, clock=lambda: now[0])
        batcher.start()
        first = asyncio.ensure_future(batcher.submit("k", 0))
        await asyncio.get_running_loop().run_in_executor(None, started.wait, 60)
        late = [asyncio.ensure_future(batcher.submit("k", i)) for i in (1, 2)]  # queued at t = 0
        await asyncio.sleep(0)
        now[0] = 0.6  # request 0 kept the planner past the others' timeout
        release.set()
        results = await asyncio.gather(first, *late, return_exceptions=True)
        await batcher.stop()
        return results

    results = asyncio.run(scenario())
    assert results[0] == 0 and all(isinstance(r, Busy) for r in results[1:])
    now[0] = 0.0

    async def in_time():
        batcher, started, release = _blocked_batcher(max_queue=100, timeout_s=0.5, clock=lambda: now[0])
        release.set()
        batcher.start()
        results = await asyncio.gather(*(batcher.submit("k", i) for i in range(3)))
        await batcher.stop()
        return results

    assert asyncio.run(in_time()) == [0, 1, 2]  # the same requests within the timeout are served
