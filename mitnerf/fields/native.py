"""The NeRF MLP of :mod:`.mlp` as a ``dr.CustomOp`` whose forward and backward run in C
(``native_mlp.c``: tiled, threaded, vectorised for ``-march=native``); Dr.Jit keeps the rest.

:func:`library` compiles it on first use (None where no compiler works: ``mode=native`` is then refused).
Data crosses as zero-copy NumPy views of evaluated Dr.Jit arrays: the encoded inputs
sample-major, the weights in canonical order (each ``nn.Linear`` weight ``[out, in]`` then its
bias), the outputs raw (activations stay in Dr.Jit). A forward that a backward will follow keeps its hidden
layers in a stash for that backward (:data:`STASH_BYTES`; the memory is the field's :class:`Stashes`).
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import hashlib
import os
import shutil
import subprocess
from pathlib import Path

import drjit as dr
import numpy as np
from drjit.auto.ad import ArrayXf, Float

from .._io import cache_entry

SOURCE = Path(__file__).with_name("native_mlp.c")
STASH_BYTES = 1 << 30
"""Bytes up to which a forward that a backward will follow keeps its activations (the trunk's and the colour
layer's: ``(depth * width + width / 2) * 4`` bytes per sample) for that backward, which then skips recomputing them;
above it the backward recomputes. Each field keeps up to two spare stashes between steps (:class:`Stashes`), so a
field may hold about 2.25 x this in all. ``benchmarks/step_time.py`` times the MLP both ways (``native`` against
``native recomputing``, and their ratio ``stash_speedup``)."""
_F = ctypes.POINTER(ctypes.c_float)


def compiled(source: Path, name: str, flags: tuple = ()) -> ctypes.CDLL | None:
    """The C file ``source`` built for this CPU (``-O3 -march=native -pthread``, then ``flags``) as a shared library,
    or None where no compiler (cc, gcc or ``$CC``) builds it. It is cached in ``$MITNERF_CACHE/native/`` under
    ``name`` and a hash of the source, the flags, the compiler and the CPU's flags, so machines sharing a cache
    never load each other's builds."""
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if cc is None or not source.exists():
        return None
    cpu = ""
    with contextlib.suppress(OSError):
        cpu = next((line for line in Path("/proc/cpuinfo").read_text().splitlines() if line.startswith("flags")), "")

    def build(tmp: Path) -> None:
        subprocess.run([cc, "-O3", "-march=native", "-pthread", *flags, "-shared", "-fPIC", str(source), "-o",
                        str(tmp / f"lib{name}.so")], check=True, capture_output=True, timeout=300)

    try:
        version = subprocess.run([cc, "--version"], capture_output=True, text=True, timeout=30).stdout
        key = hashlib.sha1(source.read_bytes() + " ".join(flags).encode() + version.encode() + cpu.encode())
        return ctypes.CDLL(str(cache_entry(f"native/{name}-{key.hexdigest()[:16]}", build) / f"lib{name}.so"))
    except (OSError, subprocess.SubprocessError):
        return None


@functools.lru_cache(maxsize=None)
def library():
    """The compiled kernel (``ctypes.CDLL``, :func:`compiled`), or None where it cannot be built."""
    lib = compiled(SOURCE, "mlp")
    if lib is None:
        return None
    L, I = ctypes.c_long, ctypes.c_int
    lib.mlp_forward.argtypes = [I, I, I, I, I, _F, _F, _F, L, _F, _F, _F]
    lib.mlp_backward.argtypes = [I, I, I, I, I, _F, _F, _F, L, _F, _F, _F, _F, _F, _F]
    lib.mlp_forward.restype = lib.mlp_backward.restype = I
    lib.mlp_stash_floats.argtypes = [I, I, I, I, I, L]
    lib.mlp_stash_floats.restype = L
    lib.mlp_set_threads.argtypes = [I]
    return lib


def _ptr(a: np.ndarray | None):
    return None if a is None else a.ctypes.data_as(_F)


def _aligned(n: int) -> np.ndarray:
    """``n`` uninitialised float32s starting on a 64-byte boundary (the kernel's vectors assume it)."""
    raw = np.empty(n + 16, np.float32)
    start = (-raw.ctypes.data % 64) // 4
    return raw[start:start + n]


class Stashes:
    """The memory of the forwards' stashes (:data:`STASH_BYTES`), kept between steps: a field holds one, so that
    each step's forward writes into pages already mapped instead of faulting fresh ones in (a stash is tens of MB).
    ``take(floats)`` lends the smallest spare buffer that holds ``floats``, or a new one an eighth larger (a batch's
    sample count may vary), as a :class:`Lease`; the backward ends it, which gives the buffer back (``give``). At most
    ``spare`` spares stay, the largest.
    """

    def __init__(self, spare: int = 2):
        self.spare, self.free = spare, []

    def take(self, floats: int) -> Lease:
        fits = [i for i, b in enumerate(self.free) if b.size >= floats]
        if not fits:
            return Lease(self, _aligned(floats + floats // 8))
        return Lease(self, self.free.pop(min(fits, key=lambda i: self.free[i].size)))

    def give(self, buffer: np.ndarray) -> None:
        self.free = sorted([*self.free, buffer], key=lambda b: -b.size)[:self.spare]


class Lease:
    """A buffer of :class:`Stashes` out on loan (``buffer``): back among the spares when :meth:`end` is called, or
    when the lease is dropped unended (a forward whose outputs never reach the loss, so that no backward comes)."""

    def __init__(self, stashes: Stashes, buffer: np.ndarray):
        self.stashes, self.buffer = stashes, buffer

    def end(self) -> None:
        if self.buffer is not None:
            self.stashes.give(self.buffer)
            self.buffer = None

    __del__ = end


def _host(x: Float) -> np.ndarray:
    """A zero-copy float32 view of an evaluated Dr.Jit array."""
    dr.eval(x)
    dr.sync_thread()
    return np.asarray(x)


@contextlib.contextmanager
def _cores_to_the_kernel():
    """Dr.Jit's idle workers keep spinning for a while after a launch and take cores from the kernel's
    threads; shrinking the pool to one thread while the kernel runs parks them (``mlp_ms.native`` of
    ``step_time/w128`` and ``step_time/w32`` in ``benchmarks/step_time.py`` measure the kernel so). The kernel
    runs as many threads as Dr.Jit's pool had (``--threads``): with one, its tiles are summed in one order and a
    run repeats bit for bit."""
    n = dr.thread_count()
    library().mlp_set_threads(max(1, n))
    dr.set_thread_count(1)
    try:
        yield
    finally:
        dr.set_thread_count(n)


class NativeMLP(dr.CustomOp):
    """``dr.custom(NativeMLP, weights, X, Dd, arch, need, stashes)`` -> ``(raw sigma [M], raw rgb 3 x [M])``.

    ``weights``: the flat canonical buffer; ``X``: the C_in encoded position arrays ``[M]``;
    ``Dd``: the C_dir encoded direction arrays (may be empty); ``arch``: ``(D, W, skip)``;
    ``need``: whether the gradients w.r.t. ``X``, ``Dd`` and ``weights`` are wanted (any: a backward will follow,
    and the forward keeps its activations for it in a buffer of ``stashes`` where they fit :data:`STASH_BYTES`)."""

    def eval(self, weights, X, Dd, arch, need, stashes):
        M = dr.width(X[0])
        self.M, self.need = M, need
        self.keep = (weights, dr.ravel(ArrayXf(X)), dr.ravel(ArrayXf(Dd)) if Dd else None)   # alive until backward
        self.W, self.X, self.Dd = (None if a is None else _host(a) for a in self.keep)
        self.dims = (*arch, len(X), len(Dd))
        sigma, rgb = np.empty(M, np.float32), np.empty(3 * M, np.float32)
        with _cores_to_the_kernel():
            self.lease = None
            if any(need):                       # a backward will follow: keep the activations if they fit
                floats = library().mlp_stash_floats(*self.dims, M)
                self.lease = stashes.take(floats) if 0 < 4 * floats <= STASH_BYTES else None
            failed = library().mlp_forward(*self.dims, _ptr(self.W), _ptr(self.X), _ptr(self.Dd), M, _ptr(sigma),
                                           _ptr(rgb), _ptr(self.lease and self.lease.buffer))
        if failed:
            raise RuntimeError(f"the native MLP does not support {self.dims}")
        return Float(sigma), [Float(rgb[k::3]) for k in range(3)]

    def backward(self):
        d_sigma, d_rgb = self.grad_out()
        ds = np.ascontiguousarray(_host(Float(d_sigma)), dtype=np.float32)
        dc = np.ascontiguousarray(_host(dr.ravel(ArrayXf([Float(c) for c in d_rgb]))), dtype=np.float32)
        grad = np.empty(self.W.size, np.float32)
        C, Cd = self.dims[3], self.dims[4]
        dX = np.empty(self.M * C, np.float32) if self.need[0] else None
        dD = np.empty(self.M * Cd, np.float32) if self.need[1] and Cd else None
        with _cores_to_the_kernel():
            failed = library().mlp_backward(*self.dims, _ptr(self.W), _ptr(self.X), _ptr(self.Dd), self.M, _ptr(ds),
                                            _ptr(dc), _ptr(grad), _ptr(dX), _ptr(dD),
                                            _ptr(self.lease and self.lease.buffer))
        if self.lease is not None:                          # spent: the backward overwrote it with gradients
            self.lease.end()
            self.lease = None
        if failed:
            raise RuntimeError(f"the native MLP's backward refused its stash for {self.dims}")
        self.set_grad_in("weights", Float(grad))
        if dX is not None:
            self.set_grad_in("X", [Float(dX[c::C]) for c in range(C)])
        if dD is not None:
            self.set_grad_in("Dd", [Float(dD[c::Cd]) for c in range(Cd)])

    def name(self):
        return "NativeMLP"


def native_mlp(weights: Float, X: list, Dd: list, arch: tuple, stashes: Stashes | None = None) -> tuple[Float, list]:
    """The NeRF MLP's raw density and colour at ``M`` samples (see :class:`NativeMLP`); ``stashes``: where the
    forward's activations find memory (a new :class:`Stashes` by default: nothing reused)."""
    need = (any(dr.grad_enabled(x) for x in X), any(dr.grad_enabled(d) for d in Dd), dr.grad_enabled(weights))
    return dr.custom(NativeMLP, weights, list(X), list(Dd), tuple(arch), need, stashes or Stashes())
