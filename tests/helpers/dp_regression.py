"""Run by tests/test_accelerate.py, alone or under ``accelerate launch --num_processes 2``: the shared
training loop fits a linear map on a fixed regression set (no sampled noise, so every process's
loss is a plain function of its rows), then each process writes its weights to ``<out>/rank<r>.json``."""

import json
import os
import sys
from pathlib import Path

import torch

from scdp.config import TrainConfig
from scdp.training.loop import train


class Rows:
    """The loop's data contract: ``len`` and ``get(index) -> batch`` with ``to(device)``."""

    def __init__(self):
        g = torch.Generator().manual_seed(0)
        self.x = torch.randn(32, 3, generator=g)
        self.y = self.x @ torch.tensor([[1.0, -2.0], [0.5, 0.0], [0.0, 3.0]]) + 0.1 * torch.randn(32, 2, generator=g)

    def __len__(self):
        return len(self.x)

    def get(self, index):
        return Batch(self.x[index], self.y[index])


class Batch:
    def __init__(self, x, y):
        self.x, self.y = x, y

    def to(self, device):
        return Batch(self.x.to(device), self.y.to(device))


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(0)
    model = torch.nn.Linear(3, 2)
    config = TrainConfig(epochs=3, batch_size=8, lr=0.05, warmup_steps=0, ema_power=None, checkpoint_every=10_000)
    loss = lambda batch, generator: torch.nn.functional.mse_loss(model(batch.x), batch.y)  # noqa: E731
    train(model, loss, Rows(), config, out / "part", save_fn=lambda *a: None, progress=False)
    rank = int(os.environ.get("RANK", "0"))  # set by `accelerate launch` for each process
    weights = {k: v.tolist() for k, v in model.state_dict().items()}
    # the loop must have closed the process group before returning (nothing left open at exit)
    weights["group_open_after_train"] = torch.distributed.is_initialized()
    (out / f"rank{rank}.json").write_text(json.dumps(weights))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
