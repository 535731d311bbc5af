"""Vector envs: several tinyrace envs per worker process, stepped through shared memory.

``BatchVectorEnv`` (``tinyrace.vector.env``) is the vector entry point of tinyrace's
ids; ``make_batch`` makes one of ``gym.make`` envs. See docs/vector.md.
"""

from tinyrace.vector.env import BatchVectorEnv
from tinyrace.vector.failures import WorkerDied
from tinyrace.vector.make import make_batch, make_carracing_vec, make_tinyrace_vec

__all__ = ["BatchVectorEnv", "WorkerDied", "make_batch", "make_carracing_vec", "make_tinyrace_vec"]
