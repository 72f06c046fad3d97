// The broad phase: the candidate contact lists of one rod (its stage state,
// owned by this module): which segment pairs and which sphere-geom pairs the
// narrow phase tests, and how far their parts moved since they were built.
#ifndef VISCERA_SRC_VSC_CONTACT_LISTS_H
#define VISCERA_SRC_VSC_CONTACT_LISTS_H

#include "viscera/vsc_world.h"
#include "vsc_rod.h"

/// Candidate lists are built with this margin, as a multiple of the radius:
/// they stay valid until a sphere or a geom moves by half of it.
#define VSC_CONTACT_MARGIN 1.0

/// Numbers kept per geom at a geom list's build: position (3), rotation (9),
/// size (3): a geom whose size changes (another intestine's capsule, whose
/// segment stretches) moves its surface as surely as one that moves.
#define VSC_GEOM_POSE_SIZE 15

struct vsc_contact_lists {
  int sphere_count;
  vsc_grid* grid;             // sphere grid for chains past the direct build's range, cell = 2 (radius + margin / 2)
  int self_count, self_capacity;
  int* self_pairs;            // candidate sphere pairs a < b, sorted (2 per pair)
  double* self_distance;      // each self pair's segment distance at the build (m)
  int geom_count, geom_capacity;
  int* geom_pairs;            // candidate (geom, sphere) pairs, sorted (2 per pair)
  double* geom_distance;      // each geom pair's distance at its build less what its sphere had moved
                              // since the spheres' snapshot then (m; -inf: never skipped)
  int* merged_pairs;          // scratch of a partial rebuild: the next geom_pairs and geom_distance
  double* merged_distance;
  unsigned char* geom_stale;  // per geom, this refresh: 1 if it moved past half the margin since its build
  int self_built;             // 0: the self pairs must be built
  int geoms_built;            // 0: the geom pairs must be built
  int built_geoms;            // geom count at the geom pairs' build
  int built_geom_capacity;
  double* sphere_xyz;         // sphere centres at the self pairs' build (3 per sphere) (m)
  double* geom_sphere_xyz;    // sphere centres at the geom pairs' build (3 per sphere) (m)
  double* geom_pose;          // geom position, rotation and size at build (VSC_GEOM_POSE_SIZE per geom), then each
                              // geom's surface motion since (1 per geom) (m)
  double* segment;            // per segment, each evaluation: midpoint (m, 3), half length (m)
  double* moved;              // per sphere, each evaluation: distance moved since the self build (m)
  double* segment_moved;      // per segment: the larger of its two spheres' `moved` (m)
  double* geom_moved;         // per sphere: distance moved since the spheres' snapshot at the last whole
                              // geom build (m); a geom rebuilt alone since then keeps its own pose
  double* build_scratch;      // per segment, during a self build: midpoint (3), grown half length (m), the
                              // same in x order (4), squared distance less squared reach (m^2)
  int* sweep_order;           // a self build's segments by midpoint x, kept for the next (segments), then
                              // its candidates' counts and slots per lo and per hi (3 x segments + 2)
  int* sweep_pairs;           // a self build's candidates: their los, his, then los by hi (3 x self_capacity)
  const vsc_geom* geoms;      // the host's geom array at build
};

/// Candidate contact lists of one rod of `sphere_count` spheres.
vsc_contact_lists* vsc_contact_lists_create(int sphere_count);
void vsc_contact_lists_destroy(vsc_contact_lists* lists);

/// Heap bytes vsc_contact_lists_create(sphere_count) allocates.
double vsc_contact_lists_memory_bytes(int sphere_count);

/// The broad phase of an evaluation: make the lists hold every pair that can
/// touch at the placed sphere centres x (m, 3 per sphere) and the world's
/// geom poses: keep them while nothing moved by half the margin, else
/// rebuild. Writes how far each part moved since the build (segment_moved,
/// geom_moved, the geoms' shifts). Returns 1, or 0 if a list overflowed (an
/// extreme pile: the narrow phase then tests every pair, with each segment's
/// midpoint and half length in `segment`; the lists are rebuilt next time).
int vsc_contact_lists_refresh(const vsc_rod* rod, vsc_contact_lists* lists, const double* x, const vsc_world* world);

/// 1 if the lists, as they stand, hold every pair that can touch with the
/// rod at control points q (m) and the world's geom poses (no sphere or geom
/// moved past half the margin since their builds); 0 if they would need a
/// rebuild. Writes nothing: the energy queries read the lists so.
int vsc_contact_lists_cover(const vsc_contact_lists* lists, const vsc_rod* rod, const double* q, const vsc_world* world);

#endif  // VISCERA_SRC_VSC_CONTACT_LISTS_H
