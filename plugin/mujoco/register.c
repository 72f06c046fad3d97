// Registers the viscera plugins when the library is loaded.
#include <mujoco/mujoco.h>

#include "intestine.h"

mjPLUGIN_LIB_INIT(viscera) { vsc_plugin_register_intestine(); }
