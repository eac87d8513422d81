"""Copy weights between a Dr.Jit model and its PyTorch twin (their initialisations differ by design)
through the canonical form: numpy arrays named as ``state_dict`` names them (``coarse.trunk.0.weight`` ...)."""

from __future__ import annotations


def drjit_to_torch(model, params: dict, torch_model) -> None:
    """Load the Dr.Jit ``params`` of ``model`` (a ``mitnerf.render.pipeline.Model``) into
    ``torch_model`` (a ``mitnerf.reference.render.pipeline.Model``), in place."""
    torch_model.load_numpy(model.to_numpy(params))


def torch_to_drjit(torch_model, model) -> dict:
    """The parameters of ``torch_model`` as Dr.Jit arrays for ``model`` (a fresh dict)."""
    return model.from_numpy(torch_model.to_numpy())
