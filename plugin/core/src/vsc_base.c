#include "viscera/vsc_base.h"

const char* vsc_status_string(vsc_status status) {
  switch (status) {
    case VSC_OK: return "ok";
    case VSC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case VSC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case VSC_ERROR_NOT_POSITIVE_DEFINITE: return "matrix not positive definite";
    case VSC_ERROR_DIVERGED: return "state diverged";
  }
  return "unknown status";
}
