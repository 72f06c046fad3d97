// Steps an MJCF scene with the viscera plugin from C, without Python: the
// loop that the sanitizer build and valgrind memcheck check (see
// tests/python/test_sanitizers.py).
//
//   viscera_scene_steps PLUGIN.so SCENE.xml STEPS
//
// Every actuator follows a slow sine over its control range, so the tools
// sweep the cavity, the grasper's jaws open and close, and grasps, contacts
// and friction all run. Exits 0 when every step leaves the plugin state finite, 1 with a
// message otherwise, 2 on a usage or load error.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <mujoco/mujoco.h>

static void print_warning(const char* message) { fprintf(stderr, "mujoco warning: %s\n", message); }

int main(int argc, char** argv) {
  if (argc < 4) {
    fprintf(stderr, "usage: %s PLUGIN.so SCENE.xml STEPS\n", argv[0]);
    return 2;
  }
  mju_user_warning = print_warning;
  mj_loadPluginLibrary(argv[1]);
  char error[1000] = "";
  mjModel* m = mj_loadXML(argv[2], NULL, error, sizeof(error));
  if (!m) {
    fprintf(stderr, "cannot load %s: %s\n", argv[2], error);
    return 2;
  }
  mjData* d = mj_makeData(m);
  if (!d) {  // a plugin's init refused (its warning above says why)
    fprintf(stderr, "cannot load %s: a plugin refused to initialise\n", argv[2]);
    mj_deleteModel(m);
    return 2;
  }
  int steps = atoi(argv[3]);
  for (int t = 0; t < steps; ++t) {
    for (int a = 0; a < m->nu; ++a) {
      double low = m->actuator_ctrlrange[2 * a], high = m->actuator_ctrlrange[2 * a + 1];
      double phase = 2.0 * 3.141592653589793 * d->time / (1.0 + 0.37 * a);
      d->ctrl[a] = m->actuator_ctrllimited[a] ? 0.5 * (low + high) + 0.45 * (high - low) * sin(phase) : 0.0;
    }
    mj_step(m, d);
    for (int i = 0; i < m->npluginstate; ++i) {
      if (!isfinite(d->plugin_state[i])) {
        fprintf(stderr, "plugin_state[%d] is not finite after step %d\n", i, t + 1);
        mj_deleteData(d);
        mj_deleteModel(m);
        return 1;
      }
    }
  }
  printf("%d steps, t = %.3f s, plugin state finite\n", steps, d->time);
  mj_deleteData(d);
  mj_deleteModel(m);
  return 0;
}
