// The MuJoCo geoms as the core sees them (see geoms.h).
#include "geoms.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

// Intestine collision filter, MuJoCo's rule: contype & conaffinity' || contype' & conaffinity.
#define INTESTINE_CONTYPE 1
#define INTESTINE_CONAFFINITY 1

// Every MuJoCo geom type collides: meshes as their convex hull (exact
// distance), height fields by vertical distance, SDF geoms as their bounding
// sphere (the paper's sphere approximation: an SDF plugin's distance is dear).
static vsc_geom_type geom_type(int mujoco_type, int* supported) {
  *supported = 1;
  switch (mujoco_type) {
    case mjGEOM_PLANE: return VSC_GEOM_PLANE;
    case mjGEOM_SPHERE: return VSC_GEOM_SPHERE;
    case mjGEOM_CAPSULE: return VSC_GEOM_CAPSULE;
    case mjGEOM_CYLINDER: return VSC_GEOM_CYLINDER;
    case mjGEOM_BOX: return VSC_GEOM_BOX;
    case mjGEOM_ELLIPSOID: return VSC_GEOM_ELLIPSOID;
    case mjGEOM_MESH: return VSC_GEOM_CONVEX;
    case mjGEOM_HFIELD: return VSC_GEOM_HEIGHTFIELD;
    case mjGEOM_SDF: return VSC_GEOM_SPHERE;
    default: *supported = 0; return VSC_GEOM_PLANE;
  }
}

// The convex hull of a mesh as outward face planes and triangles, from
// MuJoCo's hull graph (numvert, numface, vert_edgeadr, vert_globalid,
// edge_localid, face_globalid), or from the mesh faces if it has none.
static int build_convex(const mjModel* m, int mesh, vsc_convex* out) {
  const float* vert = m->mesh_vert + 3 * m->mesh_vertadr[mesh];
  const int* faces;
  int count;
  if (m->mesh_graphadr[mesh] >= 0) {
    const int* graph = m->mesh_graph + m->mesh_graphadr[mesh];
    int numvert = graph[0];
    count = graph[1];
    faces = graph + 2 + numvert + numvert + (numvert + 3 * count);
  } else {
    count = m->mesh_facenum[mesh];
    faces = m->mesh_face + 3 * m->mesh_faceadr[mesh];
  }
  double* planes = (double*)malloc(sizeof(double) * 4 * (size_t)(count > 0 ? count : 1));
  double* triangles = (double*)malloc(sizeof(double) * 9 * (size_t)(count > 0 ? count : 1));
  if (!planes || !triangles) {
    free(planes);
    free(triangles);
    return -1;
  }
  double centre[3] = {0, 0, 0};
  for (int f = 0; f < count; ++f)
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) centre[a] += vert[3 * faces[3 * f + k] + a] / (3.0 * count);
  int kept = 0;
  for (int f = 0; f < count; ++f) {
    double* t = triangles + 9 * kept;
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) t[3 * k + a] = vert[3 * faces[3 * f + k] + a];
    double u[3], v[3], n[3];
    for (int a = 0; a < 3; ++a) { u[a] = t[3 + a] - t[a]; v[a] = t[6 + a] - t[a]; }
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
    double norm = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(norm > 0.0)) continue;  // degenerate face
    double out_side = n[0] * (t[0] - centre[0]) + n[1] * (t[1] - centre[1]) + n[2] * (t[2] - centre[2]);
    double sign = out_side < 0.0 ? -1.0 : 1.0;  // orient outwards
    double* pl = planes + 4 * kept;
    for (int a = 0; a < 3; ++a) pl[a] = sign * n[a] / norm;
    pl[3] = pl[0] * t[0] + pl[1] * t[1] + pl[2] * t[2];
    ++kept;
  }
  out->face_count = kept;
  out->planes = planes;
  out->triangles = triangles;
  return 0;
}

void vsc_mujoco_geoms_free(vsc_mujoco_geoms* w) {
  for (int i = 0; w->convex && i < w->count; ++i) {
    free((void*)w->convex[i].planes);
    free((void*)w->convex[i].triangles);
  }
  free(w->convex);
  for (int i = 0; w->heightfield && i < w->count; ++i) free((void*)w->heightfield[i].vertices);
  free(w->heightfield);
  free(w->ids);
  free(w->geoms);
  memset(w, 0, sizeof(*w));
}

// 1 if the intestine may touch geom g: a type it collides with, passing the filter.
static int touchable(const mjModel* m, int g) {
  int supported;
  geom_type(m->geom_type[g], &supported);
  int filtered = (m->geom_contype[g] & INTESTINE_CONAFFINITY) || (m->geom_conaffinity[g] & INTESTINE_CONTYPE);
  return supported && filtered;
}

int vsc_mujoco_geoms_possible(const mjModel* m) {
  for (int g = 0; g < m->ngeom; ++g) {
    int supported;
    geom_type(m->geom_type[g], &supported);
    if (supported) return 1;
  }
  return 0;
}

int vsc_mujoco_geoms_create(const mjModel* m, vsc_mujoco_geoms* w) {
  memset(w, 0, sizeof(*w));
  size_t room = (size_t)(m->ngeom > 0 ? m->ngeom : 1);
  w->ids = (int*)malloc(sizeof(int) * room);
  w->geoms = (vsc_geom*)calloc(room, sizeof(vsc_geom));
  if (!w->ids || !w->geoms) {
    vsc_mujoco_geoms_free(w);
    return -1;
  }
  for (int g = 0; g < m->ngeom; ++g)
    if (touchable(m, g)) w->ids[w->count++] = g;
  w->convex = (vsc_convex*)calloc((size_t)(w->count > 0 ? w->count : 1), sizeof(vsc_convex));
  w->heightfield = (vsc_heightfield*)calloc((size_t)(w->count > 0 ? w->count : 1), sizeof(vsc_heightfield));
  if (!w->convex || !w->heightfield) {
    vsc_mujoco_geoms_free(w);
    return -1;
  }
  for (int i = 0; i < w->count; ++i) {
    int g = w->ids[i], data = m->geom_dataid[g];
    if (m->geom_type[g] == mjGEOM_MESH && data >= 0 && build_convex(m, data, &w->convex[i])) {
      vsc_mujoco_geoms_free(w);
      return -1;
    }
    if (m->geom_type[g] == mjGEOM_HFIELD && data >= 0) {
      vsc_heightfield* h = &w->heightfield[i];
      h->rows = m->hfield_nrow[data];
      h->columns = m->hfield_ncol[data];
      h->elevation = m->hfield_data + m->hfield_adr[data];
      for (int a = 0; a < 4; ++a) h->size[a] = m->hfield_size[4 * data + a];
      // its vertices' heights and slopes, once: every query would derive them again
      double* vertices = (double*)malloc(sizeof(double) * (size_t)vsc_heightfield_vertex_size(h));
      if (!vertices) {
        vsc_mujoco_geoms_free(w);
        return -1;
      }
      vsc_heightfield_vertices(h, vertices);
      h->vertices = vertices;
    }
  }
  return 0;
}

void vsc_mujoco_geoms_update(const mjModel* m, const mjData* d, double friction, vsc_mujoco_geoms* w) {
  for (int i = 0; i < w->count; ++i) {
    int g = w->ids[i], supported;
    vsc_geom* out = &w->geoms[i];
    out->type = geom_type(m->geom_type[g], &supported);
    for (int c = 0; c < 3; ++c) {
      out->position[c] = d->geom_xpos[3 * g + c];
      out->size[c] = m->geom_size[3 * g + c];
    }
    for (int c = 0; c < 9; ++c) out->rotation[c] = d->geom_xmat[9 * g + c];
    out->bound_radius = m->geom_type[g] == mjGEOM_PLANE ? 0.0 : m->geom_rbound[g];
    out->convex = &w->convex[i];
    out->heightfield = &w->heightfield[i];
    if (m->geom_type[g] == mjGEOM_SDF) out->size[0] = m->geom_rbound[g];  // bounding sphere
    out->friction = friction >= 0.0 ? friction : m->geom_friction[3 * g];
    const mjtNum* aabb = m->geom_aabb + 6 * g;  // local centre and half sizes
    for (int a = 0; a < 3; ++a) {
      const mjtNum* row = out->rotation + 3 * a;
      double centre = out->position[a] + row[0] * aabb[0] + row[1] * aabb[1] + row[2] * aabb[2];
      double half = fabs(row[0]) * aabb[3] + fabs(row[1]) * aabb[4] + fabs(row[2]) * aabb[5];
      if (m->geom_type[g] == mjGEOM_SDF) {  // collides as its bounding sphere: that is its box
        centre = out->position[a];
        half = m->geom_rbound[g];
      }
      out->box[a] = centre - half;
      out->box[3 + a] = centre + half;
    }
    if (m->body_dofnum[m->geom_bodyid[g]] == 0 && m->body_mocapid[m->geom_bodyid[g]] < 0 &&
        m->body_weldid[m->geom_bodyid[g]] == 0) {
      memset(out->linear_velocity, 0, sizeof(out->linear_velocity));  // static geom
      memset(out->angular_velocity, 0, sizeof(out->angular_velocity));
      out->is_static = 1;
    } else {
      mjtNum velocity[6];  // rotation then translation, world frame, at the geom origin
      mj_objectVelocity(m, d, mjOBJ_GEOM, g, velocity, 0);
      out->is_static = 0;
      for (int c = 0; c < 3; ++c) {
        out->angular_velocity[c] = velocity[c];
        out->linear_velocity[c] = velocity[3 + c];
      }
    }
  }
}
