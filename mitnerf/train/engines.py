"""The engines a model can be trained with, by name; torch is imported only when asked for."""

from __future__ import annotations

from ..errors import ConfigError
from .backend import Backend
from .backend_drjit import DrJitBackend
from .config import ModelConfig, TrainConfig

ENGINES = ("drjit", "torch")


def make_backend(name: str, model_cfg: ModelConfig, train_cfg: TrainConfig, dim: int, bound: float, near: float,
                 far: float) -> Backend:
    """A backend of engine ``name`` for the model; the torch engine is imported only when asked for."""
    if name == "drjit":
        cls = DrJitBackend
    elif name == "torch":
        try:
            from .backend_torch import TorchBackend as cls
        except ImportError:
            raise ConfigError("the torch backend needs PyTorch: `pip install -e .[torch]` "
                              "(torch==2.13.0, the CPU wheel), or use --backend drjit") from None
    else:
        raise ConfigError(f"unknown backend {name!r}; choose one of {', '.join(ENGINES)}")
    return cls(model_cfg, train_cfg, dim, bound, near, far)
