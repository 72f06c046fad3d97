"""The vector environments of viscera.scale.vector under their first name (the learning and
scale-out interfaces live in viscera.scale): the same objects, re-exported for programs that
import them from here."""

from viscera.scale.vector import BACKENDS, ThreadVectorEnv, make, make_threads

__all__ = ["BACKENDS", "ThreadVectorEnv", "make", "make_threads"]
