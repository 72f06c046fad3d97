// vsc_damage.c's own header: its whole API is public (viscera/vsc_damage.h).
#ifndef VISCERA_SRC_VSC_DAMAGE_H
#define VISCERA_SRC_VSC_DAMAGE_H

#include "viscera/vsc_damage.h"

#endif  // VISCERA_SRC_VSC_DAMAGE_H
