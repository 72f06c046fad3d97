"""viscera.gymnasium_env is viscera.scale.gym_env (the learning and scale-out interfaces live in viscera.scale);
this name stays for the programs that import it."""

import sys

from viscera.scale import gym_env as _module

sys.modules[__name__] = _module
