// Tissue damage: what the jaws' pinch and overstretching do to the bowel's
// wall, accumulated per control point in the host's state (VSC_DAMAGE_SIZE
// numbers each), so that copies, resets, recordings and replays keep it.
//
// - Bruise, in [0, 1]: the force-time product of the pinches held there (N s,
//   the pinch integrated over the hold's time) over the product that damages
//   the wall (`force_time_product`); 1 is histological damage. Spread between
//   the two control points around the held abscissa, in proportion to their
//   nearness (hat functions: the Catmull-Rom weights go negative).
// - Torn, 0 or 1: the wall is through. A pinch of at least
//   `perforation_pinch` perforates at the control point nearest the held
//   abscissa; a segment between two control points stretched past
//   `tear_strain` (its chord against its rest length) tears both its ends. A
//   torn point's bruise is 1.
//
// The limits and their sources are vsc_default_damage_limits's. Nothing here
// feeds back into the mechanics: a torn bowel moves as an intact one.
#ifndef VISCERA_VSC_DAMAGE_H
#define VISCERA_VSC_DAMAGE_H

/// Numbers per control point: bruise in [0, 1], torn (0 or 1).
#define VSC_DAMAGE_SIZE 2

/// Where the wall fails.
typedef struct vsc_damage_limits {
  double perforation_pinch;   ///< a pinch at least this perforates the wall (N, > 0)
  double force_time_product;  ///< pinch x time that bruises fully (N s, > 0)
  double tear_strain;         ///< axial strain of a segment that tears it (dimensionless, > 0)
} vsc_damage_limits;

/// Human small bowel where measured: perforation at a 10.3 N pinch
/// (10.3 +- 2.9 N; Heijnsdijk, de Visser, Dankelman, Gouma, Surg Endosc
/// 17:1427-1430, 2003); histological damage past a force-time product of
/// 300 N s (porcine colon: Barrie et al., Surg Endosc 32:4244-4250, 2018);
/// failure at 140 % strain (human small intestine, longitudinal: Egorov et
/// al., J Biomech 35:1417-1425, 2002).
vsc_damage_limits vsc_default_damage_limits(void);

/// A pinch of `pinch` N held `dt` s at parametric abscissa `abscissa` in
/// [0, 1] of an n-point axis: bruises the two control points around it and,
/// at or past the perforation pinch, tears the nearest. `damage`: n x
/// VSC_DAMAGE_SIZE. Returns 1 if it tore a point that was whole, else 0.
int vsc_damage_pinch(const vsc_damage_limits* limits, int n, double abscissa, double pinch, double dt,
                     double* damage);

/// Tears the ends of every segment between consecutive control points `q`
/// (m, 3 per point) stretched past the tear strain, the rest spacing being
/// `rest_length` / (n - 1) (m). Returns the count of points it tore that were
/// whole.
int vsc_damage_stretch(const vsc_damage_limits* limits, int n, double rest_length, const double* q, double* damage);

#endif  // VISCERA_VSC_DAMAGE_H
