"""Vector envs: several tinyrace envs per worker process, stepped through shared memory.

``BatchVectorEnv`` (``tinyrace.vector.env``) is the vector entry point of tinyrace's
ids; ``make_batch`` makes one of ``gym.make`` envs; ``AsyncBatch`` steps one EnvPool-style
(each worker on its own). See docs/vector.md.
"""

from tinyrace.vector.env import BatchVectorEnv
from tinyrace.vector.failures import WorkerDied
from tinyrace.vector.make import make_batch, make_carracing_vec, make_tinyrace_vec
from tinyrace.vector.pool import AsyncBatch

__all__ = [
    "AsyncBatch",
    "BatchVectorEnv",
    "WorkerDied",
    "make_batch",
    "make_carracing_vec",
    "make_tinyrace_vec",
]
