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
    ``loss_fn(batch, generator=...)``. ``save_fn(module, complete, seconds)`` writes the part
    (``seconds``: the wall time spent training it so far, resumed runs included; called with the EMA
    weights swapped in when EMA is on). ``job`` (JSON: e.g. the data's fingerprint and the model
    config) is saved with the training state, and ``resume`` refuses a saved run whose job differs,
    naming what changed. ``data.get`` returns CPU batches with a ``to(device)`` method; under
    ``accelerate launch`` on GPUs each process takes the GPU Accelerate gives it.
    """
    run = _Run(module, config, out_dir, save_fn, job, resolve_device(device), precision, len(data))
    if resume:
        run.resume()
    return run.loop(loss_fn, data, desc, progress)


class _Run:
    """One training run, in the steps :func:`_train` takes: set up (``__init__``: the module on its
    device, optimiser, schedule, EMA, generator), :meth:`resume` from a saved state, :meth:`loop`
    over the epochs, and :meth:`checkpoint` (the part and a resumable state) along the way."""

    def __init__(self, module: torch.nn.Module, config: TrainConfig, out_dir, save_fn, job: dict | None,
                 device: torch.device, precision: str, n_windows: int):
        self.job = json.loads(json.dumps({"schedule": config.to_dict(), **(job or {})}))  # as it reads back from disk
        self.module, self.config, self.save_fn, self.precision = module, config, save_fn, precision
        self.out_dir = Path(out_dir)
        self.accelerator = Accelerator(cpu=device.type == "cpu")  # processes > 1 under `accelerate launch`
        self.rank, self.world = self.accelerator.process_index, self.accelerator.num_processes
        if self.world > 1 and device.type != "cpu":
            device = self.accelerator.device  # one GPU per process
        self.device = device
        module.to(device)
        if self.world > 1 and config.batch_size < self.world:
            raise ScdpError("batch_size", f"{config.batch_size} cannot be split over {self.world} processes")
        self.job["processes"] = self.world  # a resumed run must keep its process count
        self.params = [p for p in module.parameters() if p.requires_grad]
        self.steps_per_epoch = math.ceil(n_windows / config.batch_size)
        self.total = max(self.steps_per_epoch * config.epochs, config.min_steps)
        self.opt = torch.optim.AdamW(self.params, lr=config.lr, weight_decay=config.weight_decay,
                                     fused=device.type == "cuda" or None)
        self.sched = get_cosine_schedule_with_warmup(self.opt, min(config.warmup_steps, self.total // 2), self.total)
        self.ema = (EMAModel(self.params, use_ema_warmup=True, power=config.ema_power, foreach=True)
                    if config.ema_power else None)
        self.gen = torch.Generator().manual_seed(config.seed)
        self.step, self.losses, self.resumed_from = 0, [], 0
        self.started, self.seconds_before = time.perf_counter(), 0.0
        self.epoch_rng = None  # the generator's state when the current epoch drew its order
        self.state_file, self.state_json = self.out_dir / "train_state.safetensors", self.out_dir / "train_state.json"

    def resume(self) -> None:
        """Continue from the saved state; refused when there is none, or it is another job's."""
        if not self.state_json.exists():
            raise ScdpError("--resume", f"{self.out_dir} holds no interrupted training to resume (no train_state.json)")
        # the state file is the one source of truth: its metadata holds the JSON, written in one piece
        tensors, stored = load_tensors_and_metadata(self.state_file, "--resume")
        meta = json.loads(stored["state"]) if "state" in stored else json.loads(self.state_json.read_text())
        job = self.job
        changed = sorted(k for k in set(job) | set(meta.get("job", {})) if meta.get("job", {}).get(k) != job.get(k))
        if "job" in meta and changed:
            raise ScdpError("--resume", f"the saved run differs in {', '.join(changed)}; start afresh with --force")
        if meta.get("total_steps") != self.total:
            raise ScdpError("--resume", f"the saved run has {meta.get('total_steps')} steps, this config {self.total}")
        self.module.load_state_dict({k[6:]: v for k, v in tensors.items() if k.startswith("model.")}, strict=False)
        self.opt.load_state_dict(_unflatten_optimizer(tensors, meta["optimizer"]))
        self.sched.load_state_dict(meta["scheduler"])
        if self.ema is not None:
            self.ema.shadow_params = [tensors[f"ema.{i}"].to(self.device) for i in range(len(self.params))]
            self.ema.optimization_step = meta["ema_step"]
        self.gen.set_state(tensors["rng"])
        self.epoch_rng = tensors.get("rng_epoch")
        self.step, self.losses, self.resumed_from = meta["step"], meta["losses"], meta["step"]
        self.seconds_before = float(meta.get("seconds", 0.0))

    def checkpoint(self, complete: bool) -> None:
        """The training state (optimiser, schedule, EMA, generator, step) and the part, by the main process."""
        if not self.accelerator.is_main_process:
            return
        ema, params = self.ema, self.params
        tensors, opt_meta = _flatten_optimizer(self.opt)
        tensors.update({f"model.{k}": v for k, v in self.module.state_dict().items()})
        tensors["rng"] = self.gen.get_state()
        if self.epoch_rng is not None:
            tensors["rng_epoch"] = self.epoch_rng
        if ema is not None:
            tensors.update({f"ema.{i}": p for i, p in enumerate(ema.shadow_params)})
        self.out_dir.mkdir(parents=True, exist_ok=True)
        seconds = self.seconds_before + time.perf_counter() - self.started
        state = {"step": self.step, "total_steps": self.total, "job": self.job, "losses": self.losses, "optimizer": opt_meta,
                 "seconds": seconds, "device": str(self.device), "precision": self.precision,
                 "scheduler": self.sched.state_dict(), "ema_step": ema.optimization_step if ema else None}
        save_tensors(self.state_file, tensors, metadata={"state": json.dumps(state)})
        write_json(self.state_json, state)  # a readable copy; a kill between the two writes leaves it one checkpoint behind
        if ema is not None:
            ema.store(params)
            ema.copy_to(params)
        self.save_fn(self.module, complete, seconds)
        if ema is not None:
            ema.restore(params)

    def epoch_order(self, n: int) -> torch.Tensor:
        """This epoch's shuffled window order; a run resumed mid-epoch draws the order it had."""
        gen = self.gen
        if self.step % self.steps_per_epoch and self.epoch_rng is not None:
            now = gen.get_state()
            gen.set_state(self.epoch_rng)
            order = torch.randperm(n, generator=gen)
            gen.set_state(now)
        else:
            self.epoch_rng = gen.get_state()
            order = torch.randperm(n, generator=gen)
        return order.to(self.device)

    def optimise(self, loss: torch.Tensor) -> torch.Tensor:
        """One optimiser step on ``loss`` (the gradients averaged over the processes), the EMA's, and the step counted;
        returns the loss, detached."""
        self.opt.zero_grad(set_to_none=True)
        loss.backward()
        if self.world > 1:  # data parallel: every process steps with the mean gradient
            for p in self.params:
                p.grad = self.accelerator.reduce(p.grad if p.grad is not None else torch.zeros_like(p), reduction="mean")
        self.opt.step()
        self.sched.step()
        if self.ema is not None:
            self.ema.step(self.params)
        self.step += 1
        return loss.detach()

    def loop(self, loss_fn, data, desc: str, progress: bool) -> TrainResult:
        """Every epoch left, checkpointing every ``checkpoint_every`` steps and at the end."""
        config, accelerator, rank, world, device = self.config, self.accelerator, self.rank, self.world, self.device
        noise = self.gen if world == 1 else torch.Generator().manual_seed(config.seed + 7919 * (rank + 1) + self.step)
        self.module.train()
        data = data.to(device) if hasattr(data, "to") else data  # every window on the device once, not a batch a step
        bar = tqdm(total=self.total, initial=self.step, desc=desc, unit="step",
                   disable=not (progress and accelerator.is_main_process), dynamic_ncols=True, mininterval=0.5)
        pending: list[torch.Tensor] = []  # this epoch's losses not yet read back (one host sync per SYNC_EVERY steps)
        running, count = 0.0, 0

        def read_losses() -> None:
            """Read the pending losses back (one sync), refuse a non-finite one, show the running mean."""
            nonlocal running, count
            if not pending:
                return
            values = torch.stack(pending).tolist()
            first = self.step - len(values)
            for n, value in enumerate(values):
                if not math.isfinite(value):
                    raise ScdpError("loss", f"became {value} at step {first + n}; lower the learning rate")
            for value in values:  # in step order, as float64: the epoch's mean as it has always been summed
                running += value
            count += len(values)
            pending.clear()
            bar.set_postfix(epoch=(self.step - 1) // self.steps_per_epoch + 1, loss=f"{running / max(count, 1):.4f}",
                            refresh=False)

        while self.step < self.total:
            order = self.epoch_order(len(data))
            running, count = 0.0, 0
            for b in range(self.step % self.steps_per_epoch, self.steps_per_epoch):  # a resumed epoch skips what is done
                batch = order[b * config.batch_size:(b + 1) * config.batch_size]
                rows = batch[rank::world] if len(batch) >= world else batch[-1:]  # this process's slice
                pending.append(self.optimise(loss_fn(data.get(rows).to(device), generator=noise)))
                bar.update(1)
                if self.step % SYNC_EVERY == 0:
                    read_losses()
                if self.step % config.checkpoint_every == 0 and self.step < self.total:
                    read_losses()  # never save weights that a non-finite loss has already reached
                    self.checkpoint(complete=False)
                if self.step >= self.total:  # a min_steps budget can end inside an epoch
                    break
            read_losses()
            self.losses.append(running / max(count, 1))
        bar.close()
        self.checkpoint(complete=True)
        accelerator.wait_for_everyone()
        if world > 1:  # close the process group while the interpreter is whole (see the module docstring)
            accelerator.end_training()
        self.module.eval()
        return TrainResult(self.step, self.losses, self.resumed_from, self.precision)
