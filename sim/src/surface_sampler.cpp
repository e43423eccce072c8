#include "surface_sampler.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace fleetslam::sim::detail {
namespace {

struct GeomFrame {
  Eigen::Matrix3d R;
  Eigen::Vector3d p;
  Eigen::Vector3f to_world(const Eigen::Vector3d& local) const { return (R * local + p).cast<float>(); }
};

// Number of samples along a length, at least one.
int count_along(double length_m, double spacing_m) {
  return std::max(1, static_cast<int>(std::ceil(length_m / spacing_m)));
}

// A rectangle in the geom frame: centre c, half-extent vectors u and v; cell centres of a grid.
void sample_rectangle(const GeomFrame& frame, const Eigen::Vector3d& c, const Eigen::Vector3d& u,
                      const Eigen::Vector3d& v, double spacing_m, std::vector<Eigen::Vector3f>* out) {
  const int nu = count_along(2.0 * u.norm(), spacing_m);
  const int nv = count_along(2.0 * v.norm(), spacing_m);
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      const double a = -1.0 + (2.0 * i + 1.0) / nu;
      const double b = -1.0 + (2.0 * j + 1.0) / nv;
      out->push_back(frame.to_world(c + a * u + b * v));
    }
  }
}

// Fibonacci lattice on the unit sphere, scaled per axis (sphere, ellipsoid) and offset.
void sample_ellipsoid(const GeomFrame& frame, const Eigen::Vector3d& radii, const Eigen::Vector3d& centre,
                      double zmin_unit, double spacing_m, std::vector<Eigen::Vector3f>* out) {
  const double r = radii.maxCoeff();
  const double area = 4.0 * M_PI * r * r * (1.0 - zmin_unit) / 2.0;
  const int n = std::max(4, static_cast<int>(area / (spacing_m * spacing_m)));
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (1.0 - zmin_unit) * (i + 0.5) / n;
    const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * i;
    const Eigen::Vector3d unit(rho * std::cos(phi), rho * std::sin(phi), z);
    out->push_back(frame.to_world(centre + radii.cwiseProduct(unit)));
  }
}

void sample_cylinder_side(const GeomFrame& frame, double radius, double half_height, double spacing_m,
                          std::vector<Eigen::Vector3f>* out) {
  const int around = count_along(2.0 * M_PI * radius, spacing_m);
  const int along = count_along(2.0 * half_height, spacing_m);
  for (int i = 0; i < around; ++i) {
    const double angle = 2.0 * M_PI * (i + 0.5) / around;
    for (int j = 0; j < along; ++j) {
      const double z = -half_height + (2.0 * j + 1.0) * half_height / along;
      out->push_back(frame.to_world(Eigen::Vector3d(radius * std::cos(angle), radius * std::sin(angle), z)));
    }
  }
}

void sample_disc(const GeomFrame& frame, double radius, double z, double spacing_m, std::vector<Eigen::Vector3f>* out) {
  const int rings = count_along(radius, spacing_m);
  for (int k = 0; k < rings; ++k) {
    const double rr = radius * (k + 0.5) / rings;
    const int around = count_along(2.0 * M_PI * rr, spacing_m);
    for (int i = 0; i < around; ++i) {
      const double angle = 2.0 * M_PI * (i + 0.5) / around;
      out->push_back(frame.to_world(Eigen::Vector3d(rr * std::cos(angle), rr * std::sin(angle), z)));
    }
  }
}

// Triangles get points in proportion to their area; the fractional remainder carries over so small
// triangles are still represented, deterministically.
void sample_mesh(const mjModel* m, int mesh_id, const GeomFrame& frame, double spacing_m,
                 std::vector<Eigen::Vector3f>* out) {
  const float* vert = m->mesh_vert + 3 * m->mesh_vertadr[mesh_id];
  const int* face = m->mesh_face + 3 * m->mesh_faceadr[mesh_id];
  double carry = 0.0;
  for (int f = 0; f < m->mesh_facenum[mesh_id]; ++f) {
    Eigen::Vector3d v[3];
    for (int k = 0; k < 3; ++k) {
      const float* p = vert + 3 * face[3 * f + k];
      v[k] = Eigen::Vector3d(p[0], p[1], p[2]);
    }
    const double area = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).norm();
    carry += area / (spacing_m * spacing_m);
    const int n = static_cast<int>(carry);
    carry -= n;
    const int grid = static_cast<int>(std::ceil(std::sqrt(2.0 * n)));
    int placed = 0;
    for (int i = 0; i < grid && placed < n; ++i) {
      for (int j = 0; j + i < grid && placed < n; ++j, ++placed) {
        const double a = (i + 1.0 / 3.0) / grid;
        const double b = (j + 1.0 / 3.0) / grid;
        out->push_back(frame.to_world(v[0] + a * (v[1] - v[0]) + b * (v[2] - v[0])));
      }
    }
  }
}

bool is_visible(const mjModel* m, int g) {
  if (m->geom_group[g] < 0 || m->geom_group[g] > 2) return false;
  const int material = m->geom_matid[g];
  const float alpha = material >= 0 ? m->mat_rgba[4 * material + 3] : m->geom_rgba[4 * g + 3];
  return alpha > 0.0f;
}

// Bounds of the finite geometry, used to clip infinite planes.
void finite_bounds(const mjModel* m, const mjData* d, Eigen::Vector3d* lo, Eigen::Vector3d* hi) {
  *lo = Eigen::Vector3d::Constant(1e300);
  *hi = Eigen::Vector3d::Constant(-1e300);
  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_type[g] == mjGEOM_PLANE) continue;
    const Eigen::Vector3d p = Eigen::Map<const Eigen::Vector3d>(d->geom_xpos + 3 * g);
    const double r = m->geom_rbound[g];
    *lo = lo->cwiseMin(p - Eigen::Vector3d::Constant(r));
    *hi = hi->cwiseMax(p + Eigen::Vector3d::Constant(r));
  }
  if ((*lo).x() > (*hi).x()) {
    *lo = Eigen::Vector3d::Constant(-5.0);
    *hi = Eigen::Vector3d::Constant(5.0);
  }
}

}  // namespace

std::vector<Eigen::Vector3f> sample_static_surfaces(const mjModel* m, const mjData* d,
                                                    const std::vector<int>& excluded_bodies, double spacing_m) {
  if (!(spacing_m > 0.0)) throw std::invalid_argument("surface sampling spacing must be positive");
  Eigen::Vector3d lo;
  Eigen::Vector3d hi;
  finite_bounds(m, d, &lo, &hi);
  std::vector<Eigen::Vector3f> points;
  for (int g = 0; g < m->ngeom; ++g) {
    const int body = m->geom_bodyid[g];
    if (!is_visible(m, g)) continue;
    // A geom belongs to a robot when its body or one of the body's ancestors is a robot body.
    bool excluded = false;
    for (int b = body; b > 0 && !excluded; b = m->body_parentid[b]) {
      excluded = std::find(excluded_bodies.begin(), excluded_bodies.end(), b) != excluded_bodies.end();
    }
    if (excluded) continue;
    GeomFrame frame;
    frame.R = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(d->geom_xmat + 9 * g);
    frame.p = Eigen::Map<const Eigen::Vector3d>(d->geom_xpos + 3 * g);
    const Eigen::Vector3d s = Eigen::Map<const Eigen::Vector3d>(m->geom_size + 3 * g);
    const Eigen::Vector3d ex = Eigen::Vector3d::UnitX();
    const Eigen::Vector3d ey = Eigen::Vector3d::UnitY();
    const Eigen::Vector3d ez = Eigen::Vector3d::UnitZ();
    switch (m->geom_type[g]) {
      case mjGEOM_PLANE: {
        // Size 0 means infinite: clipped to the other geometry's bounds, as seen in the plane's frame (the
        // extent of the bounds box's corners along the plane's axes), not centred on the plane's origin.
        Eigen::Vector2d local_lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
        Eigen::Vector2d local_hi = -local_lo;
        for (int corner = 0; corner < 8; ++corner) {
          const Eigen::Vector3d c((corner & 1) != 0 ? hi.x() : lo.x(), (corner & 2) != 0 ? hi.y() : lo.y(),
                                  (corner & 4) != 0 ? hi.z() : lo.z());
          const Eigen::Vector2d q = (frame.R.transpose() * (c - frame.p)).head<2>();
          local_lo = local_lo.cwiseMin(q);
          local_hi = local_hi.cwiseMax(q);
        }
        const bool infinite_x = !(s.x() > 0.0);
        const bool infinite_y = !(s.y() > 0.0);
        const double cx = infinite_x ? 0.5 * (local_lo.x() + local_hi.x()) : 0.0;
        const double cy = infinite_y ? 0.5 * (local_lo.y() + local_hi.y()) : 0.0;
        const double sx = infinite_x ? 0.5 * (local_hi.x() - local_lo.x()) : s.x();
        const double sy = infinite_y ? 0.5 * (local_hi.y() - local_lo.y()) : s.y();
        if (!(sx > 0.0 && sy > 0.0)) break;  // no other geometry to clip to
        sample_rectangle(frame, Eigen::Vector3d(cx, cy, 0.0), sx * ex, sy * ey, spacing_m, &points);
        break;
      }
      case mjGEOM_BOX:
        for (int axis = 0; axis < 3; ++axis) {
          const Eigen::Vector3d n = Eigen::Vector3d::Unit(axis);
          const Eigen::Vector3d u = Eigen::Vector3d::Unit((axis + 1) % 3) * s((axis + 1) % 3);
          const Eigen::Vector3d v = Eigen::Vector3d::Unit((axis + 2) % 3) * s((axis + 2) % 3);
          sample_rectangle(frame, n * s(axis), u, v, spacing_m, &points);
          sample_rectangle(frame, -n * s(axis), u, v, spacing_m, &points);
        }
        break;
      case mjGEOM_SPHERE:
        sample_ellipsoid(frame, Eigen::Vector3d::Constant(s.x()), Eigen::Vector3d::Zero(), -1.0, spacing_m, &points);
        break;
      case mjGEOM_ELLIPSOID:
        sample_ellipsoid(frame, s, Eigen::Vector3d::Zero(), -1.0, spacing_m, &points);
        break;
      case mjGEOM_CYLINDER:
        sample_cylinder_side(frame, s.x(), s.y(), spacing_m, &points);
        sample_disc(frame, s.x(), s.y(), spacing_m, &points);
        sample_disc(frame, s.x(), -s.y(), spacing_m, &points);
        break;
      case mjGEOM_CAPSULE:
        sample_cylinder_side(frame, s.x(), s.y(), spacing_m, &points);
        sample_ellipsoid(frame, Eigen::Vector3d::Constant(s.x()), s.y() * ez, 0.0, spacing_m, &points);
        sample_ellipsoid(frame, Eigen::Vector3d(s.x(), s.x(), -s.x()), -s.y() * ez, 0.0, spacing_m, &points);
        break;
      case mjGEOM_MESH:
        sample_mesh(m, m->geom_dataid[g], frame, spacing_m, &points);
        break;
      default:
        break;  // height fields and others: not sampled
    }
  }
  return points;
}

}  // namespace fleetslam::sim::detail
