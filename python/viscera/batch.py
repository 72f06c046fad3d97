"""The batched stepping of viscera.scale.batch under its first name (the learning and scale-out
interfaces live in viscera.scale): the same objects, re-exported for programs that import them
from here."""

from viscera.scale.batch import FULLPHYSICS, BatchResult, BatchStepper, available_cores, serial_step, state_of

__all__ = ["FULLPHYSICS", "BatchResult", "BatchStepper", "available_cores", "serial_step", "state_of"]
