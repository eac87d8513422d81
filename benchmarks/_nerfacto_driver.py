"""nerfstudio's nerfacto on the CPU for a wall-clock budget, then renders of chosen test views: the side of
``benchmarks/nerfacto.py`` that runs in a separate interpreter holding nerfstudio (mitnerf's has none; this file
imports no mitnerf).

nerfacto is built as ``ns-train nerfacto blender-data`` builds it (nerfstudio 1.1.5's ``method_configs``: 4096
rays a batch, proposal networks, SO3xR3 camera optimiser, Adam at 1e-2 with exponential decay), with only what
the CPU needs changed: the pure-torch hash grid (``implementation="torch"``, no tiny-cuda-nn), float32 (no mixed
precision), the single-process data manager (images cached in memory before the clock starts), no viewer, no
writer, no LPIPS (torchmetrics' LPIPS needs torchvision, which has no CPU wheel for this torch: a stub stands in
for it and is never called). The background is white: the Blender parser composites the RGBA views over white and
the model renders over white. Training is nerfstudio's ``Trainer.train_iteration`` written out (the trainer module
imports the viewer and torchvision): callbacks, loss, backward, optimiser and scheduler steps; the clock is read
before each step and training stops at the first step that starts past the budget.

    python benchmarks/_nerfacto_driver.py --data DIR --time-budget S --threads T --views 0,66 --out DIR

writes ``OUT/renders.npy`` (float32 ``[n, H, W, 3]``, the views in the order given) and ``OUT/run.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import types
from pathlib import Path

NERFACTO_OPTIMIZERS = {     # (lr, final lr, decay steps) of nerfstudio 1.1.5's method_configs["nerfacto"]
    "proposal_networks": (1e-2, 1e-4, 200000), "fields": (1e-2, 1e-4, 200000), "camera_opt": (1e-3, 1e-4, 5000)}


def parse(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, required=True, help="a Blender folder (transforms_{train,test}.json)")
    p.add_argument("--time-budget", type=float, required=True, help="seconds of training")
    p.add_argument("--threads", type=int, default=2, help="CPU threads (OpenMP and torch)")
    p.add_argument("--views", required=True, help="test-view indices to render, comma-separated")
    p.add_argument("--out", type=Path, required=True, help="folder for renders.npy and run.json")
    p.add_argument("--rays", type=int, default=4096, help="rays a training batch (nerfacto's default 4096)")
    p.add_argument("--seed", type=int, default=42, help="nerfstudio's default machine seed")
    return p.parse_args(argv)


def without_lpips(torch) -> None:
    """nerfacto builds torchmetrics' LPIPS, which needs torchvision: a module that stands in for it (never called)."""
    class NoLPIPS(torch.nn.Module):
        def forward(self, *args):
            raise RuntimeError("LPIPS is unavailable here (no torchvision)")

    stub = types.ModuleType("torchmetrics.image.lpip")
    stub.LearnedPerceptualImagePatchSimilarity = lambda *args, **kwargs: NoLPIPS()
    sys.modules["torchmetrics.image.lpip"] = stub


def build(args):
    """nerfacto's data manager, model and optimisers on the CPU, and the model's and data's training callbacks."""
    from nerfstudio.cameras.camera_optimizers import CameraOptimizerConfig
    from nerfstudio.data.datamanagers.base_datamanager import VanillaDataManagerConfig
    from nerfstudio.data.dataparsers.blender_dataparser import BlenderDataParserConfig
    from nerfstudio.engine.callbacks import TrainingCallbackAttributes
    from nerfstudio.engine.optimizers import AdamOptimizerConfig, Optimizers
    from nerfstudio.engine.schedulers import ExponentialDecaySchedulerConfig
    from nerfstudio.models.nerfacto import NerfactoModelConfig

    data = VanillaDataManagerConfig(dataparser=BlenderDataParserConfig(data=args.data, alpha_color="white"),
                                    train_num_rays_per_batch=args.rays, eval_num_rays_per_batch=args.rays)
    dm = data.setup(device="cpu", test_mode="test")
    model_cfg = NerfactoModelConfig(eval_num_rays_per_chunk=4096, average_init_density=0.01,
                                    camera_optimizer=CameraOptimizerConfig(mode="SO3xR3"),
                                    background_color="white", implementation="torch")
    model = model_cfg.setup(scene_box=dm.train_dataset.scene_box, num_train_data=len(dm.train_dataset),
                            metadata=dm.train_dataset.metadata, device="cpu", grad_scaler=None).to("cpu")
    groups = {**dm.get_param_groups(), **model.get_param_groups()}
    opt = Optimizers({name: {"optimizer": AdamOptimizerConfig(lr=lr, eps=1e-15),
                             "scheduler": ExponentialDecaySchedulerConfig(lr_final=final, max_steps=steps)}
                      for name, (lr, final, steps) in NERFACTO_OPTIMIZERS.items()}, groups)
    attrs = TrainingCallbackAttributes(optimizers=opt, grad_scaler=None, pipeline=None, trainer=None)
    return dm, model, opt, dm.get_training_callbacks(attrs) + model.get_training_callbacks(attrs)


def train(dm, model, opt, callbacks, budget: float) -> tuple[int, float]:
    """Steps until the budget is spent (checked before each step): (steps, seconds)."""
    from nerfstudio.engine.callbacks import TrainingCallbackLocation as At

    model.train()
    step, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < budget:
        for cb in callbacks:
            cb.run_callback_at_location(step, location=At.BEFORE_TRAIN_ITERATION)
        opt.zero_grad_all()
        rays, batch = dm.next_train(step)
        out = model(rays)
        losses = model.get_loss_dict(out, batch, model.get_metrics_dict(out, batch))
        sum(losses.values()).backward()
        opt.optimizer_step_all()
        opt.scheduler_step_all(step)
        for cb in callbacks:
            cb.run_callback_at_location(step, location=At.AFTER_TRAIN_ITERATION)
        step += 1
    return step, time.perf_counter() - t0


def main(argv=None) -> int:
    args = parse(argv)
    os.environ["OMP_NUM_THREADS"] = os.environ["MKL_NUM_THREADS"] = str(args.threads)   # before torch loads
    import random
    from importlib.metadata import version

    import numpy as np
    import torch

    torch.set_num_threads(args.threads)
    random.seed(args.seed), np.random.seed(args.seed), torch.manual_seed(args.seed)
    without_lpips(torch)
    t0 = time.perf_counter()
    dm, model, opt, callbacks = build(args)
    setup_s = time.perf_counter() - t0
    steps, train_s = train(dm, model, opt, callbacks, args.time_budget)
    views = [int(v) for v in args.views.split(",")]
    model.eval()
    t0 = time.perf_counter()
    with torch.no_grad():
        rgb = [model.get_outputs_for_camera(dm.eval_dataset.cameras[i:i + 1])["rgb"].numpy() for i in views]
    render_s = time.perf_counter() - t0
    args.out.mkdir(parents=True, exist_ok=True)
    np.save(args.out / "renders.npy", np.stack(rgb).astype(np.float32))
    run = {"steps": steps, "train_s": train_s, "render_s": render_s, "setup_s": setup_s, "views": views,
           "threads": torch.get_num_threads(), "rays": args.rays, "seed": args.seed,
           "torch": torch.__version__, "nerfstudio": version("nerfstudio")}
    (args.out / "run.json").write_text(json.dumps(run, indent=1) + "\n")
    print(f"nerfacto: {steps} steps in {train_s:.0f} s ({args.threads} threads), {len(views)} views rendered "
          f"in {render_s:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
