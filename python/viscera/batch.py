"""viscera.batch is viscera.scale.batch (the learning and scale-out interfaces live in viscera.scale);
this name stays for the programs that import it."""

import sys

from viscera.scale import batch as _module

sys.modules[__name__] = _module
