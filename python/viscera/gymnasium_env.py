"""The gymnasium adapter of viscera.scale.gym_env under its first name (the learning and
scale-out interfaces live in viscera.scale): the same objects, re-exported for programs that
import them from here. Needs gymnasium."""

from viscera.scale.gym_env import IMAGE_BOUNDS, IMAGE_KEYS, KNOWN_BOUNDS, TaskEnv

__all__ = ["IMAGE_BOUNDS", "IMAGE_KEYS", "KNOWN_BOUNDS", "TaskEnv"]
