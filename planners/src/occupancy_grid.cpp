#include "fleetslam/planners/occupancy_grid.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <string>
#include <utility>

#include "fleetslam/core/error.hpp"

namespace fleetslam::planners {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr float kInfF = std::numeric_limits<float>::infinity();

// 1D squared Euclidean distance transform of a sampled function f (infinity: no site), into d
// (Felzenszwalb & Huttenlocher 2012, "Distance Transforms of Sampled Functions", algorithm DT(f)).
void distance_transform_1d(const std::vector<double>& f, std::vector<double>& d, std::vector<int>& v,
                           std::vector<double>& z) {
  const int n = static_cast<int>(f.size());
  const auto at = [](const std::vector<double>& a, int i) { return a[static_cast<std::size_t>(i)]; };
  const auto parabola_cut = [&](int q, int p) {
    return ((at(f, q) + static_cast<double>(q) * q) - (at(f, p) + static_cast<double>(p) * p)) / (2.0 * (q - p));
  };
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (!std::isfinite(at(f, q))) continue;
    while (k >= 0 && parabola_cut(q, v[static_cast<std::size_t>(k)]) <= at(z, k)) --k;
    ++k;
    v[static_cast<std::size_t>(k)] = q;
    z[static_cast<std::size_t>(k)] = k == 0 ? -kInf : parabola_cut(q, v[static_cast<std::size_t>(k - 1)]);
    z[static_cast<std::size_t>(k + 1)] = kInf;
  }
  if (k < 0) {
    std::fill(d.begin(), d.end(), kInf);
    return;
  }
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (at(z, j + 1) < q) ++j;
    const int p = v[static_cast<std::size_t>(j)];
    d[static_cast<std::size_t>(q)] = static_cast<double>(q - p) * (q - p) + at(f, p);
  }
}

// Distances (in metres) from every cell's centre to the nearest cell where is_site is true.
std::vector<float> distance_transform(int width, int height, double resolution_m,
                                      const std::function<bool(std::size_t)>& is_site) {
  const std::size_t w = static_cast<std::size_t>(width);
  const std::size_t h = static_cast<std::size_t>(height);
  std::vector<double> grid(w * h);
  for (std::size_t i = 0; i < w * h; ++i) grid[i] = is_site(i) ? 0.0 : kInf;
  const std::size_t n = std::max(w, h);
  std::vector<double> f(n), d(n), z(n + 1);
  std::vector<int> v(n);
  for (std::size_t x = 0; x < w; ++x) {  // columns
    f.resize(h);
    d.resize(h);
    for (std::size_t y = 0; y < h; ++y) f[y] = grid[y * w + x];
    distance_transform_1d(f, d, v, z);
    for (std::size_t y = 0; y < h; ++y) grid[y * w + x] = d[y];
  }
  for (std::size_t y = 0; y < h; ++y) {  // rows
    f.resize(w);
    d.resize(w);
    for (std::size_t x = 0; x < w; ++x) f[x] = grid[y * w + x];
    distance_transform_1d(f, d, v, z);
    for (std::size_t x = 0; x < w; ++x) grid[y * w + x] = d[x];
  }
  std::vector<float> out(w * h);
  for (std::size_t i = 0; i < w * h; ++i) {
    out[i] = std::isfinite(grid[i]) ? static_cast<float>(std::sqrt(grid[i]) * resolution_m) : kInfF;
  }
  return out;
}

void check_config(const OccupancyGridConfig& c) {
  const std::string where = "occupancy_grid";
  if (!(c.resolution_m > 0.0)) throw InputError(where + ".resolution_m", "must be positive");
  if (!c.bounds_xy_m.empty()) {
    if (c.bounds_xy_m.size() != 4) {
      throw InputError(where + ".bounds_xy_m", "needs 4 numbers [min_x, min_y, max_x, max_y]");
    }
    if (!(c.bounds_xy_m[2] > c.bounds_xy_m[0]) || !(c.bounds_xy_m[3] > c.bounds_xy_m[1])) {
      throw InputError(where + ".bounds_xy_m", "max must exceed min");
    }
  }
  if (c.obstacle_min_height_m < c.floor_tolerance_m) {
    throw InputError(where + ".obstacle_min_height_m", "must not be below floor_tolerance_m");
  }
  if (!(c.obstacle_max_height_m > c.obstacle_min_height_m)) {
    throw InputError(where + ".obstacle_max_height_m", "must exceed obstacle_min_height_m");
  }
}

}  // namespace

OccupancyGrid::OccupancyGrid(const Config& config) : config_(config) { check_config(config_); }

void OccupancyGrid::update(const core::PointCloud& cloud_world, const std::vector<SensorView>& views_world) {
  stats_ = OccupancyGridStats{};
  stats_.points = cloud_world.size();
  const double res = config_.resolution_m;

  // Bounds: fixed, or the finite points' xy bounds padded.
  Eigen::Vector2d min_xy, max_xy;
  if (!config_.bounds_xy_m.empty()) {
    min_xy = {config_.bounds_xy_m[0], config_.bounds_xy_m[1]};
    max_xy = {config_.bounds_xy_m[2], config_.bounds_xy_m[3]};
  } else {
    min_xy = Eigen::Vector2d::Constant(kInf);
    max_xy = Eigen::Vector2d::Constant(-kInf);
    for (const Eigen::Vector3f& p : cloud_world.points) {
      if (!p.allFinite()) continue;
      min_xy = min_xy.cwiseMin(p.head<2>().cast<double>());
      max_xy = max_xy.cwiseMax(p.head<2>().cast<double>());
    }
    if (!(min_xy.x() <= max_xy.x())) {  // no finite point
      min_xy.setZero();
      max_xy.setZero();
    }
    min_xy.array() -= config_.margin_m;
    max_xy.array() += config_.margin_m;
    min_xy = (min_xy / res).array().floor().matrix() * res;  // cell edges on multiples of the resolution
  }
  // Fixed bounds end at max ([min, max)); bounds built to cover the cloud hold its farthest points too:
  // with no margin a point at max lies on the far edge, in one more cell (ceil dropped that wall row).
  const auto cells_along = [&](double span_m) {
    return config_.bounds_xy_m.empty() ? std::floor(span_m / res) + 1.0 : std::ceil(span_m / res);
  };
  const double cells_x = cells_along(max_xy.x() - min_xy.x());
  const double cells_y = cells_along(max_xy.y() - min_xy.y());
  if (cells_x * cells_y > static_cast<double>(config_.max_cells)) {
    throw InputError("occupancy_grid.max_cells",
                     "the map's bounds need " + std::to_string(static_cast<long long>(cells_x)) + " x " +
                         std::to_string(static_cast<long long>(cells_y)) + " cells, more than " +
                         std::to_string(config_.max_cells) + " (set bounds_xy_m or a coarser resolution_m)");
  }
  origin_world_ = min_xy;
  width_ = std::max(1, static_cast<int>(cells_x));
  height_ = std::max(1, static_cast<int>(cells_y));

  const std::size_t n = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  std::vector<std::uint8_t> floor_seen(n, 0);
  std::vector<int> obstacle_count(n, 0);
  const double floor_z = config_.floor_height_m;
  for (const Eigen::Vector3f& p : cloud_world.points) {
    if (!p.allFinite()) {
      ++stats_.non_finite_points;
      continue;
    }
    const std::optional<CellIndex> cell = cell_of(p.head<2>().cast<double>());
    if (!cell) {
      ++stats_.outside_points;
      continue;
    }
    const double h = static_cast<double>(p.z()) - floor_z;
    if (std::abs(h) <= config_.floor_tolerance_m) {
      floor_seen[index(*cell)] = 1;
      ++stats_.floor_points;
    } else if (h >= config_.obstacle_min_height_m && h <= config_.obstacle_max_height_m) {
      ++obstacle_count[index(*cell)];
      ++stats_.obstacle_points;
    }
  }
  std::vector<std::uint8_t> crossed(n, 0);
  if (config_.carve_rays) {
    for (const SensorView& view : views_world) carve(view, obstacle_count, crossed);
  }
  cells_.assign(n, CellState::kUnknown);
  for (std::size_t i = 0; i < n; ++i) {
    if (obstacle_count[i] >= config_.min_obstacle_points) {
      cells_[i] = CellState::kOccupied;
    } else if (floor_seen[i] != 0) {
      cells_[i] = CellState::kFree;
    } else if (crossed[i] != 0 && obstacle_count[i] == 0) {  // a cell with a few obstacle points stays unknown
      cells_[i] = CellState::kFree;
      ++stats_.carved_cells;
    }
  }
  recompute_clearances();
}

// Walks each ray's cells in xy (Amanatides & Woo 1987) and marks those it crosses entirely below the top
// of the obstacle band and above the floor, up to carve_stop_short_m before its point (a rising ray: up
// to the first cell holding obstacle points). Only the part over the grid (and a cell around it) is
// walked: a far point, or a sensor far outside, would walk cells nobody keeps (1e13 of them for a point
// at 1e12 m).
void OccupancyGrid::carve(const SensorView& view, const std::vector<int>& obstacle_count,
                          std::vector<std::uint8_t>& crossed) {
  const Eigen::Vector3d o = view.origin_world.cast<double>();
  if (!o.allFinite()) return;
  const double res = config_.resolution_m;
  const double top = config_.floor_height_m + config_.obstacle_max_height_m;
  // A descending ray below the floor is over a drop (a stairwell, a pit): the floor there was not seen.
  const double bottom = config_.floor_height_m - config_.floor_tolerance_m;
  const Eigen::Vector2d g = (o.head<2>() - origin_world_) / res;  // origin in cell units
  for (const Eigen::Vector3f& pf : view.points_world) {
    const Eigen::Vector3d p = pf.cast<double>();
    if (!p.allFinite()) continue;
    ++stats_.rays;
    const Eigen::Vector3d d = p - o;
    const double length = d.norm();
    if (!(length > config_.carve_stop_short_m)) continue;
    const double t_end = 1.0 - config_.carve_stop_short_m / length;  // ray parameter where carving stops
    // Heights along the ray: z(t) = o.z + t d.z; carve the part below `top`, t in [t_begin, t_stop). A
    // rising ray stops at the first cell holding obstacle points (see the header: beyond it, it may be
    // passing over a thing taller than the sensor whose top the map lacks).
    double t_begin = 0.0;
    double t_stop = t_end;
    const bool rising = d.z() > 0.0;
    if (o.z() > top) {  // a sensor above the band: from where the ray enters it
      if (!(d.z() < 0.0)) continue;
      t_begin = (top - o.z()) / d.z();
    } else if (rising) {
      t_stop = std::min(t_end, (top - o.z()) / d.z());
    }
    if (d.z() < 0.0) t_stop = std::min(t_stop, (bottom - o.z()) / d.z());
    const Eigen::Vector2d step_cells = d.head<2>() / res;  // cells per unit t
    // Clipped to the grid grown by a cell on each side (cells beyond it are never marked; the margin
    // keeps the last cell inside from being taken for the one the carving ends in).
    bool misses = false;
    for (int axis = 0; axis < 2; ++axis) {
      const double lo = -1.0;
      const double hi = (axis == 0 ? width_ : height_) + 1.0;
      if (step_cells[axis] == 0.0) {
        misses = misses || !(g[axis] >= lo && g[axis] < hi);
        continue;
      }
      double t0 = (lo - g[axis]) / step_cells[axis];
      double t1 = (hi - g[axis]) / step_cells[axis];
      if (t0 > t1) std::swap(t0, t1);
      t_begin = std::max(t_begin, t0);
      t_stop = std::min(t_stop, t1);
    }
    if (misses || !(t_stop > t_begin)) continue;
    int x = static_cast<int>(std::floor(g.x() + t_begin * step_cells.x()));
    int y = static_cast<int>(std::floor(g.y() + t_begin * step_cells.y()));
    const int sx = step_cells.x() > 0.0 ? 1 : -1;
    const int sy = step_cells.y() > 0.0 ? 1 : -1;
    const double dx = std::abs(step_cells.x()) > 0.0 ? 1.0 / std::abs(step_cells.x()) : kInf;  // t per cell
    const double dy = std::abs(step_cells.y()) > 0.0 ? 1.0 / std::abs(step_cells.y()) : kInf;
    const double fx = g.x() + t_begin * step_cells.x() - std::floor(g.x() + t_begin * step_cells.x());
    const double fy = g.y() + t_begin * step_cells.y() - std::floor(g.y() + t_begin * step_cells.y());
    // t at the next cell edge across x (y); never for a ray that does not move along x (y).
    double next_x = dx < kInf ? t_begin + (sx > 0 ? 1.0 - fx : fx) * dx : kInf;
    double next_y = dy < kInf ? t_begin + (sy > 0 ? 1.0 - fy : fy) * dy : kInf;
    for (;;) {
      if (std::min(next_x, next_y) >= t_stop) break;  // the cell the carving ends in is not crossed entirely
      if (x >= 0 && y >= 0 && x < width_ && y < height_) {
        const std::size_t i = index({x, y});
        if (rising && obstacle_count[i] > 0) break;
        crossed[i] = 1;
      }
      if (next_x < next_y) {
        x += sx;
        next_x += dx;
      } else {
        y += sy;
        next_y += dy;
      }
    }
  }
}

void OccupancyGrid::set_cells(const Eigen::Vector2d& origin_world, int width, int height,
                              std::vector<CellState> cells) {
  if (width < 0 || height < 0 ||
      cells.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
    throw InputError("occupancy_grid.set_cells", "cell count does not match width x height");
  }
  stats_ = OccupancyGridStats{};
  origin_world_ = origin_world;
  width_ = width;
  height_ = height;
  cells_ = std::move(cells);
  recompute_clearances();
}

template <class Fn>
void OccupancyGrid::for_cells_in(const std::vector<Disk>& disks_world, Fn&& fn) {
  const double res = config_.resolution_m;
  for (const Disk& disk : disks_world) {
    if (!disk.center_world.allFinite() || !std::isfinite(disk.radius_m)) continue;
    const int r = static_cast<int>(std::ceil(disk.radius_m / res)) + 1;
    const Eigen::Vector2d rel = (disk.center_world - origin_world_) / res;
    const int cx = static_cast<int>(std::floor(rel.x()));
    const int cy = static_cast<int>(std::floor(rel.y()));
    for (int y = std::max(cy - r, 0); y <= std::min(cy + r, height_ - 1); ++y) {
      for (int x = std::max(cx - r, 0); x <= std::min(cx + r, width_ - 1); ++x) {
        const CellIndex cell{x, y};
        if ((center_of(cell) - disk.center_world).norm() <= disk.radius_m) fn(cells_[index(cell)]);
      }
    }
  }
}

void OccupancyGrid::block(const std::vector<Disk>& disks_world) {
  for_cells_in(disks_world, [](CellState& state) { state = CellState::kOccupied; });
  recompute_clearances();
}

void OccupancyGrid::mark_free(const std::vector<Disk>& disks_world, bool clear_occupied) {
  for_cells_in(disks_world, [clear_occupied](CellState& state) {
    if (state == CellState::kUnknown || clear_occupied) state = CellState::kFree;
  });
  recompute_clearances();
}

std::optional<Eigen::Vector2d> nearest_cell_centre(const OccupancyGrid& grid, const Eigen::Vector2d& p_world, double radius_m,
                                                   const std::function<bool(const Eigen::Vector2d&)>& accept) {
  if (!p_world.allFinite() || !std::isfinite(radius_m)) return std::nullopt;
  const double res = grid.resolution_m();
  const Eigen::Vector2d rel = (p_world - grid.origin_world()) / res;
  const int cx = static_cast<int>(std::floor(rel.x()));
  const int cy = static_cast<int>(std::floor(rel.y()));
  const int r = static_cast<int>(std::ceil(radius_m / res)) + 1;
  std::optional<Eigen::Vector2d> best;
  double best_m = std::numeric_limits<double>::infinity();
  for (int y = cy - r; y <= cy + r; ++y) {
    for (int x = cx - r; x <= cx + r; ++x) {
      const CellIndex cell{x, y};
      if (!grid.contains(cell)) continue;
      const Eigen::Vector2d c = grid.center_of(cell);
      const double d = (c - p_world).norm();
      if (d <= radius_m && d < best_m && accept(c)) {
        best = c;
        best_m = d;
      }
    }
  }
  return best;
}

bool line_of_sight(const OccupancyGrid& grid, const Eigen::Vector2d& a_world, const Eigen::Vector2d& b_world) {
  if (!a_world.allFinite() || !b_world.allFinite()) return false;
  const double length_m = (b_world - a_world).norm();
  const int steps = std::max(1, static_cast<int>(std::ceil(length_m / (0.5 * grid.resolution_m()))));
  for (int i = 0; i <= steps; ++i) {
    const Eigen::Vector2d p = a_world + (b_world - a_world) * (static_cast<double>(i) / steps);
    const std::optional<CellIndex> cell = grid.cell_of(p);
    if (cell && grid.state(*cell) == CellState::kOccupied) return false;
  }
  return true;
}

double unknown_area_in_sight_m2(const OccupancyGrid& grid, const Eigen::Vector2d& p_world, double radius_m) {
  if (!p_world.allFinite() || !(radius_m > 0.0) || !std::isfinite(radius_m)) return 0.0;
  const double res = grid.resolution_m();
  const Eigen::Vector2d rel = (p_world - grid.origin_world()) / res;
  const int r = static_cast<int>(std::ceil(radius_m / res)) + 1;
  const int cx = static_cast<int>(std::floor(rel.x()));
  const int cy = static_cast<int>(std::floor(rel.y()));
  std::size_t cells = 0;
  for (int y = std::max(0, cy - r); y <= std::min(grid.height() - 1, cy + r); ++y) {
    for (int x = std::max(0, cx - r); x <= std::min(grid.width() - 1, cx + r); ++x) {
      const CellIndex cell{x, y};
      if (grid.state(cell) != CellState::kUnknown) continue;
      const Eigen::Vector2d c = grid.center_of(cell);
      if ((c - p_world).norm() <= radius_m && line_of_sight(grid, p_world, c)) ++cells;
    }
  }
  return static_cast<double>(cells) * res * res;
}

std::optional<Eigen::Vector2d> nearest_traversable(const OccupancyGrid& grid, const Eigen::Vector2d& p_world,
                                                   double radius_m, UnknownCells unknown) {
  if (!p_world.allFinite()) return std::nullopt;
  if (grid.traversable(p_world, unknown)) return p_world;
  return nearest_cell_centre(grid, p_world, radius_m,
                             [&grid, unknown](const Eigen::Vector2d& c) { return grid.traversable(c, unknown); });
}

void OccupancyGrid::recompute_clearances() {
  stats_.free_cells = stats_.occupied_cells = stats_.unknown_cells = 0;
  for (CellState s : cells_) {
    if (s == CellState::kFree) ++stats_.free_cells;
    if (s == CellState::kOccupied) ++stats_.occupied_cells;
    if (s == CellState::kUnknown) ++stats_.unknown_cells;
  }
  const double res = config_.resolution_m;
  clearance_occupied_m_ =
      distance_transform(width_, height_, res, [this](std::size_t i) { return cells_[i] == CellState::kOccupied; });
  clearance_blocked_m_ =
      distance_transform(width_, height_, res, [this](std::size_t i) { return cells_[i] != CellState::kFree; });
  // Outside the grid is unknown too: the nearest outside cell's centre is straight across the nearest
  // border, (x + 1) cells from cell x's (or width - x across the far one).
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      const int cells = std::min({x + 1, y + 1, width_ - x, height_ - y});
      float& c = clearance_blocked_m_[index({x, y})];
      c = std::min(c, static_cast<float>(cells * res));
    }
  }
}

std::optional<CellIndex> OccupancyGrid::cell_of(const Eigen::Vector2d& p_world) const {
  if (!p_world.allFinite()) return std::nullopt;
  const Eigen::Vector2d rel = (p_world - origin_world_) / config_.resolution_m;
  if (rel.x() < 0.0 || rel.y() < 0.0 || rel.x() >= width_ || rel.y() >= height_) return std::nullopt;
  const CellIndex cell{static_cast<int>(rel.x()), static_cast<int>(rel.y())};
  if (!contains(cell)) return std::nullopt;  // rounding at the far edge
  return cell;
}

Eigen::Vector2d OccupancyGrid::center_of(const CellIndex& cell) const {
  return origin_world_ + config_.resolution_m * Eigen::Vector2d(cell.x + 0.5, cell.y + 0.5);
}

CellState OccupancyGrid::state(const CellIndex& cell) const {
  return contains(cell) ? cells_[index(cell)] : CellState::kUnknown;
}

double OccupancyGrid::clearance_m(const CellIndex& cell, UnknownCells unknown) const {
  if (!contains(cell)) return 0.0;
  const std::vector<float>& field = unknown == UnknownCells::kFree ? clearance_occupied_m_ : clearance_blocked_m_;
  return static_cast<double>(field[index(cell)]);
}

bool OccupancyGrid::traversable(const CellIndex& cell, UnknownCells unknown) const {
  if (!contains(cell)) return false;
  const CellState s = cells_[index(cell)];
  if (s == CellState::kOccupied) return false;
  if (s == CellState::kUnknown && unknown == UnknownCells::kOccupied) return false;
  // In cells (header): grid distances are square roots of integers, at least 5e-4 cells apart up to 1000
  // cells, and the float clearance is within 1e-4 of its distance there.
  constexpr double kTieCells = 1e-4;
  const double limit_cells = config_.robot_radius_m / config_.resolution_m;
  return clearance_m(cell, unknown) / config_.resolution_m > limit_cells + kTieCells;
}

bool OccupancyGrid::traversable(const Eigen::Vector2d& p_world, UnknownCells unknown) const {
  const std::optional<CellIndex> cell = cell_of(p_world);
  return cell && traversable(*cell, unknown);
}

void OccupancyGrid::place_frontier_goal(Frontier& frontier) const {
  const double search_m = config_.frontier_goal_search_m;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (const CellIndex& c : frontier.cells) sum += center_of(c);
  frontier.centroid_world = sum / static_cast<double>(frontier.size());
  // Goal: the conservative-traversable cell nearest the centroid (first in scan order on ties).
  const int r = static_cast<int>(std::ceil(search_m / config_.resolution_m));
  const std::optional<CellIndex> cc = cell_of(frontier.centroid_world);
  double best = kInf;
  if (cc) {
    for (int gy = cc->y - r; gy <= cc->y + r; ++gy) {
      for (int gx = cc->x - r; gx <= cc->x + r; ++gx) {
        const CellIndex g{gx, gy};
        if (!traversable(g, UnknownCells::kOccupied)) continue;
        const double d = (center_of(g) - frontier.centroid_world).norm();
        if (d <= search_m && d < best) {
          best = d;
          frontier.goal_world = center_of(g);
          frontier.has_goal = true;
        }
      }
    }
  }
  if (!frontier.has_goal) frontier.goal_world = frontier.centroid_world;
}

std::vector<Frontier> OccupancyGrid::frontiers() const {
  const auto is_frontier = [this](const CellIndex& c) {
    if (state(c) != CellState::kFree) return false;
    const CellIndex n4[4] = {{c.x + 1, c.y}, {c.x - 1, c.y}, {c.x, c.y + 1}, {c.x, c.y - 1}};
    for (const CellIndex& n : n4) {
      if (contains(n) && cells_[index(n)] == CellState::kUnknown) return true;
    }
    return false;
  };
  std::vector<std::uint8_t> visited(cells_.size(), 0);
  std::vector<Frontier> result;
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      const CellIndex seed{x, y};
      if (visited[index(seed)] != 0 || !is_frontier(seed)) continue;
      Frontier frontier;
      std::queue<CellIndex> queue;
      queue.push(seed);
      visited[index(seed)] = 1;
      while (!queue.empty()) {
        const CellIndex c = queue.front();
        queue.pop();
        frontier.cells.push_back(c);
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const CellIndex n{c.x + dx, c.y + dy};
            if (!contains(n) || visited[index(n)] != 0 || !is_frontier(n)) continue;
            visited[index(n)] = 1;
            queue.push(n);
          }
        }
      }
      if (static_cast<int>(frontier.size()) < config_.min_frontier_cells) continue;
      // A long frontier (the whole rim of the seen floor is often one cluster, its centroid in the middle
      // of the floor) is cut into pieces of consecutive cells in breadth-first order, each with its goal.
      const std::size_t piece = config_.max_frontier_cells > 0 ? static_cast<std::size_t>(config_.max_frontier_cells)
                                                                : frontier.size();
      const std::size_t pieces = (frontier.size() + piece - 1) / piece;
      for (std::size_t p = 0; p < pieces; ++p) {
        Frontier part;
        // Even pieces (no tiny remainder): piece p takes cells [p * n / pieces, (p + 1) * n / pieces).
        const std::size_t begin = p * frontier.size() / pieces;
        const std::size_t end = (p + 1) * frontier.size() / pieces;
        part.cells.assign(frontier.cells.begin() + static_cast<std::ptrdiff_t>(begin),
                          frontier.cells.begin() + static_cast<std::ptrdiff_t>(end));
        place_frontier_goal(part);
        result.push_back(std::move(part));
      }
    }
  }
  return result;
}

std::vector<double> OccupancyGrid::geodesic_distances_m(const Eigen::Vector2d& from_world, UnknownCells unknown) const {
  std::vector<double> dist(cells_.size(), kInf);
  const std::optional<CellIndex> start = cell_of(from_world);
  if (!start || !traversable(*start, unknown)) return dist;
  using Item = std::pair<double, std::size_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
  dist[index(*start)] = 0.0;
  open.push({0.0, index(*start)});
  const double res = config_.resolution_m;
  const double diag = std::sqrt(2.0) * res;
  while (!open.empty()) {
    const auto [d, i] = open.top();
    open.pop();
    if (d > dist[i]) continue;
    const CellIndex c{static_cast<int>(i % static_cast<std::size_t>(width_)),
                      static_cast<int>(i / static_cast<std::size_t>(width_))};
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx == 0 && dy == 0) continue;
        const CellIndex n{c.x + dx, c.y + dy};
        if (!traversable(n, unknown)) continue;
        // A diagonal step needs both side cells traversable (no corner cutting).
        if (dx != 0 && dy != 0 &&
            (!traversable(CellIndex{c.x + dx, c.y}, unknown) || !traversable(CellIndex{c.x, c.y + dy}, unknown))) {
          continue;
        }
        const double nd = d + (dx != 0 && dy != 0 ? diag : res);
        const std::size_t ni = index(n);
        if (nd < dist[ni]) {
          dist[ni] = nd;
          open.push({nd, ni});
        }
      }
    }
  }
  return dist;
}

}  // namespace fleetslam::planners
