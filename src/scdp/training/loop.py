"""The one training loop, shared by every trainable part.

    for epoch: for batch in shuffled(data): loss = loss_fn(batch); AdamW step; LR schedule; EMA

* AdamW with a cosine schedule after linear warm-up (diffusers' schedule), optional EMA of
  the weights (diffusers' ``EMAModel``, warm-up with ``power``); the EMA weights are saved.
* A tqdm bar shows epoch and loss.
* Every ``checkpoint_every`` steps (and at the end) the part is saved together with a
  resumable training state (``train_state.safetensors`` + ``train_state.json``): optimiser,
  schedule, EMA, RNG and step. ``resume=True`` continues from it, so an interruption loses at
  most one checkpoint interval.
* Every random draw comes from one seeded ``torch.Generator``.
* ``device`` (see :mod:`scdp.devices`): the module and every batch go there; noise and
  shuffling are still drawn from the CPU generator, so a seed draws alike on every device.
* Data parallel under Hugging Face Accelerate: ``accelerate launch --num_processes N scdp train
  ...`` runs N processes that shuffle alike, each take a 1/N slice of every batch (with noise
  from a generator of its own) and average their gradients before each step; the main process
  alone writes the checkpoint, in the same layout. One process (plain ``scdp train``) draws
  exactly as before. When the processes are done, :func:`train` closes their process group
  (``destroy_process_group``) before it returns: a gloo group left open until the interpreter
  exits can abort a process at exit ("terminate called without an active exception", SIGABRT)
  when its worker threads still hold tensors while Python is torn down, which a busy core made
  likely enough to fail a test. So one data-parallel :func:`train` runs per process, as in
  ``scdp train``.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import torch
from accelerate import Accelerator
from diffusers.optimization import get_cosine_schedule_with_warmup
from diffusers.training_utils import EMAModel
from tqdm.auto import tqdm

from scdp.config import TrainConfig
from scdp.devices import resolve as resolve_device
from scdp.devices import training_precision
from scdp.errors import ScdpError
from scdp.io import write_json
from scdp.policies.checkpoint import load_tensors_and_metadata, save_tensors


@dataclass
class TrainResult:
    steps: int
    losses: list[float]  # mean loss of each epoch
    resumed_from: int
    precision: str = "fp32"  # "tf32" on a CUDA device (scdp.devices.training_precision)


def _flatten_optimizer(opt: torch.optim.Optimizer) -> tuple[dict, dict]:
    state = opt.state_dict()
    tensors, meta = {}, {"param_groups": state["param_groups"], "scalars": {}}
    for pid, pstate in state["state"].items():
        for key, value in pstate.items():
            if torch.is_tensor(value):
                tensors[f"opt.{pid}.{key}"] = value
            else:
                meta["scalars"][f"{pid}.{key}"] = value
    return tensors, meta


def _unflatten_optimizer(tensors: dict, meta: dict) -> dict:
    state: dict = {}
    for name, value in tensors.items():
        if name.startswith("opt."):
            _, pid, key = name.split(".", 2)
            state.setdefault(int(pid), {})[key] = value
    for name, value in meta["scalars"].items():
        pid, key = name.split(".", 1)
        state.setdefault(int(pid), {})[key] = value
    return {"state": state, "param_groups": meta["param_groups"]}


SYNC_EVERY = 25  # steps between reading the losses back (a host-device sync on a GPU), and at every epoch's end


def train(module: torch.nn.Module, loss_fn, data, config: TrainConfig, out_dir, save_fn, *,
          resume: bool = False, desc: str = "train", progress: bool = True, job: dict | None = None,
          device="cpu") -> TrainResult:
    """Optimise the trainable parameters of ``module`` on ``loss_fn(batch, generator)``: see
    :func:`_train`. On a CUDA device matrix products and convolutions run in TF32 while it trains
    (:func:`scdp.devices.training_precision`; the result's ``precision`` says which)."""
    device = resolve_device(device)
    with training_precision(device) as precision:
        return _train(module, loss_fn, data, config, out_dir, save_fn, resume=resume, desc=desc, progress=progress,
                      job=job, device=device, precision=precision)


def _train(module: torch.nn.Module, loss_fn, data, config: TrainConfig, out_dir, save_fn, *,
          resume: bool = False, desc: str = "train", progress: bool = True, job: dict | None = None,
          device="cpu", precision: str = "fp32") -> TrainResult:
    """Optimise the trainable parameters of ``module`` on ``loss_fn(batch, generator)``.

    ``data`` has ``len`` and ``get(index_tensor) -> batch``; the loss is called as
    ``loss_fn(batch, generator=...)``. ``save_fn(module, complete, seconds)``
    writes the part (``seconds``: the wall time spent training it so far, resumed runs included) (called with the EMA weights swapped in when EMA is on). ``job`` (JSON:
    e.g. the data's fingerprint and the model config) is saved with the training state, and
    ``resume`` refuses a saved run whose job differs, naming what changed. ``data.get`` returns
    CPU batches with a ``to(device)`` method; under ``accelerate launch`` on GPUs each process
    takes the GPU Accelerate gives it.
    """  # noqa: E501 (docstring text kept byte-identical)
    job = json.loads(json.dumps({"schedule": config.to_dict(), **(job or {})}))  # as it reads back from disk
    out_dir = Path(out_dir)
    device = resolve_device(device)
    accelerator = Accelerator(cpu=device.type == "cpu")  # processes > 1 under `accelerate launch`
    rank, world = accelerator.process_index, accelerator.num_processes
    if world > 1 and device.type != "cpu":
        device = accelerator.device  # one GPU per process
    module.to(device)
    if world > 1 and config.batch_size < world:
        raise ScdpError("batch_size", f"{config.batch_size} cannot be split over {world} processes")
    job["processes"] = world  # a resumed run must keep its process count
    params = [p for p in module.parameters() if p.requires_grad]
    steps_per_epoch = math.ceil(len(data) / config.batch_size)
    total = max(steps_per_epoch * config.epochs, config.min_steps)
    opt = torch.optim.AdamW(params, lr=config.lr, weight_decay=config.weight_decay, fused=device.type == "cuda" or None)
    sched = get_cosine_schedule_with_warmup(opt, min(config.warmup_steps, total // 2), total)
    ema = EMAModel(params, use_ema_warmup=True, power=config.ema_power, foreach=True) if config.ema_power else None
    gen = torch.Generator().manual_seed(config.seed)
    step, losses, resumed_from = 0, [], 0
    started, seconds_before = time.perf_counter(), 0.0
    epoch_rng = None  # the generator's state when the current epoch drew its order

    state_file, state_json = out_dir / "train_state.safetensors", out_dir / "train_state.json"
    if resume and not state_json.exists():
        raise ScdpError("--resume", f"{out_dir} holds no interrupted training to resume (no train_state.json)")
    if resume:  # the state file is the one source of truth: its metadata holds the JSON, written in one piece
        tensors, stored = load_tensors_and_metadata(state_file, "--resume")
        meta = json.loads(stored["state"]) if "state" in stored else json.loads(state_json.read_text())
        changed = sorted(k for k in set(job) | set(meta.get("job", {})) if meta.get("job", {}).get(k) != job.get(k))
        if "job" in meta and changed:
            raise ScdpError("--resume", f"the saved run differs in {', '.join(changed)}; start afresh with --force")
        if meta.get("total_steps") != total:
            raise ScdpError("--resume", f"the saved run has {meta.get('total_steps')} steps, this config {total}")
        module.load_state_dict({k[6:]: v for k, v in tensors.items() if k.startswith("model.")}, strict=False)
        opt.load_state_dict(_unflatten_optimizer(tensors, meta["optimizer"]))
        sched.load_state_dict(meta["scheduler"])
        if ema is not None:
            ema.shadow_params = [tensors[f"ema.{i}"].to(device) for i in range(len(params))]
            ema.optimization_step = meta["ema_step"]
        gen.set_state(tensors["rng"])
        epoch_rng = tensors.get("rng_epoch")
        step, losses, resumed_from = meta["step"], meta["losses"], meta["step"]
        seconds_before = float(meta.get("seconds", 0.0))
    noise = gen if world == 1 else torch.Generator().manual_seed(config.seed + 7919 * (rank + 1) + step)

    def checkpoint(complete: bool):
        if not accelerator.is_main_process:
            return
        tensors, opt_meta = _flatten_optimizer(opt)
        tensors.update({f"model.{k}": v for k, v in module.state_dict().items()})
        tensors["rng"] = gen.get_state()
        if epoch_rng is not None:
            tensors["rng_epoch"] = epoch_rng
        if ema is not None:
            tensors.update({f"ema.{i}": p for i, p in enumerate(ema.shadow_params)})
        out_dir.mkdir(parents=True, exist_ok=True)
        seconds = seconds_before + time.perf_counter() - started
        state = {"step": step, "total_steps": total, "job": job, "losses": losses, "optimizer": opt_meta, "seconds": seconds,
                 "device": str(device), "precision": precision,
                 "scheduler": sched.state_dict(), "ema_step": ema.optimization_step if ema else None}
        save_tensors(state_file, tensors, metadata={"state": json.dumps(state)})
        write_json(state_json, state)  # a readable copy; a kill between the two writes leaves it one checkpoint behind
        if ema is not None:
            ema.store(params)
            ema.copy_to(params)
        save_fn(module, complete, seconds)
        if ema is not None:
            ema.restore(params)

    module.train()
    data = data.to(device) if hasattr(data, "to") else data  # every window on the device once, not a batch a step
    bar = tqdm(total=total, initial=step, desc=desc, unit="step", disable=not (progress and accelerator.is_main_process),
               dynamic_ncols=True, mininterval=0.5)
    pending: list[torch.Tensor] = []  # this epoch's losses not yet read back (one host sync per SYNC_EVERY steps)
    running, count = 0.0, 0

    def read_losses() -> None:
        """Read the pending losses back (one sync), refuse a non-finite one, show the running mean."""
        nonlocal running, count
        if not pending:
            return
        values = torch.stack(pending).tolist()
        first = step - len(values)
        for n, value in enumerate(values):
            if not math.isfinite(value):
                raise ScdpError("loss", f"became {value} at step {first + n}; lower the learning rate")
        for value in values:  # in step order, as float64: the epoch's mean as it has always been summed
            running += value
        count += len(values)
        pending.clear()
        bar.set_postfix(epoch=(step - 1) // steps_per_epoch + 1, loss=f"{running / max(count, 1):.4f}", refresh=False)

    while step < total:
        if step % steps_per_epoch and epoch_rng is not None:  # resumed mid-epoch: the same order as before
            now = gen.get_state()
            gen.set_state(epoch_rng)
            order = torch.randperm(len(data), generator=gen)
            gen.set_state(now)
        else:
            epoch_rng = gen.get_state()
            order = torch.randperm(len(data), generator=gen)
        order = order.to(device)
        running, count = 0.0, 0
        for b in range(step % steps_per_epoch, steps_per_epoch):  # a resumed epoch skips what is done
            batch = order[b * config.batch_size:(b + 1) * config.batch_size]
            rows = batch[rank::world] if len(batch) >= world else batch[-1:]  # this process's slice
            loss = loss_fn(data.get(rows).to(device), generator=noise)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            if world > 1:  # data parallel: every process steps with the mean gradient
                for p in params:
                    p.grad = accelerator.reduce(p.grad if p.grad is not None else torch.zeros_like(p), reduction="mean")
            opt.step()
            sched.step()
            if ema is not None:
                ema.step(params)
            step += 1
            pending.append(loss.detach())
            bar.update(1)
            if step % SYNC_EVERY == 0:
                read_losses()
            if step % config.checkpoint_every == 0 and step < total:
                read_losses()  # never save weights that a non-finite loss has already reached
                checkpoint(complete=False)
            if step >= total:  # a min_steps budget can end inside an epoch
                break
        read_losses()
        losses.append(running / max(count, 1))
    bar.close()
    checkpoint(complete=True)
    accelerator.wait_for_everyone()
    if world > 1:  # close the process group while the interpreter is whole (see the module docstring)
        accelerator.end_training()
    module.eval()
    return TrainResult(step, losses, resumed_from, precision)
