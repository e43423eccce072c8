#include "fleetslam/sim/motion.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace fleetslam::sim {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;

constexpr double kPi = 3.14159265358979323846;
constexpr double kMinRotateInPlaceRad = PurePursuit::kMinRotateInPlaceDeg * kPi / 180.0;
// Heading error to yaw rate while turning on the spot (1/s): settles within about a second.
constexpr double kRotateGain = 2.0;

double wrap_pi(double angle_rad) { return std::remainder(angle_rad, 2.0 * kPi); }

Vector6d knot_values(const TimedWaypoint& knot) {
  Vector6d values;
  values << knot.p_world, knot.rpy_rad;
  return values;
}

void validate_knots(const std::vector<TimedWaypoint>& knots) {
  if (knots.size() < 2) {
    throw std::invalid_argument("SmoothTrajectory: needs at least 2 knots, got " + std::to_string(knots.size()));
  }
  for (std::size_t i = 0; i < knots.size(); ++i) {
    if (!knots[i].p_world.allFinite() || !knots[i].rpy_rad.allFinite()) {
      throw std::invalid_argument("SmoothTrajectory: knot " + std::to_string(i) + " has a non-finite value");
    }
    if (i > 0 && knots[i].t_ns <= knots[i - 1].t_ns) {
      throw std::invalid_argument("SmoothTrajectory: knot times must increase (knot " + std::to_string(i) + " at " +
                                  std::to_string(knots[i].t_ns) + " ns)");
    }
  }
}

// Each angle moves by less than half a turn between knots, so 179 deg -> -179 deg turns by 2 deg.
void unwrap_angles(std::vector<TimedWaypoint>* knots) {
  for (std::size_t i = 1; i < knots->size(); ++i) {
    const Eigen::Vector3d& previous = (*knots)[i - 1].rpy_rad;
    Eigen::Vector3d& current = (*knots)[i].rpy_rad;
    for (int axis = 0; axis < 3; ++axis) current[axis] = previous[axis] + wrap_pi(current[axis] - previous[axis]);
  }
}

// Second derivatives M_i of the cubic spline through (t_i, y_i) with zero first derivative at both ends:
// the tridiagonal system h_{i-1} M_{i-1} + 2 (h_{i-1} + h_i) M_i + h_i M_{i+1} = 6 (d_i - d_{i-1}), with
// d_i the slope of interval i, closed by 2 h_0 M_0 + h_0 M_1 = 6 d_0 and its mirror at the end
// (Numerical Recipes 3.3). Diagonally dominant, so the Thomas algorithm is stable.
std::vector<Vector6d> clamped_spline_second_derivatives(const std::vector<double>& t_s,
                                                        const std::vector<Vector6d>& y) {
  const std::size_t n = t_s.size();
  std::vector<double> sub(n, 0.0), diag(n, 0.0), sup(n, 0.0);
  std::vector<Vector6d> rhs(n, Vector6d::Zero());
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double h = t_s[i + 1] - t_s[i];
    const Vector6d slope = (y[i + 1] - y[i]) / h;
    diag[i] += 2.0 * h;
    sup[i] = h;
    rhs[i] += 6.0 * slope;
    sub[i + 1] = h;
    diag[i + 1] += 2.0 * h;
    rhs[i + 1] -= 6.0 * slope;
  }
  for (std::size_t i = 1; i < n; ++i) {
    const double w = sub[i] / diag[i - 1];
    diag[i] -= w * sup[i - 1];
    rhs[i] -= w * rhs[i - 1];
  }
  std::vector<Vector6d> second(n);
  second[n - 1] = rhs[n - 1] / diag[n - 1];
  for (std::size_t i = n - 1; i-- > 0;) second[i] = (rhs[i] - sup[i] * second[i + 1]) / diag[i];
  return second;
}

Eigen::Matrix3d rotation_from_rpy(const Eigen::Vector3d& rpy_rad) {
  return (Eigen::AngleAxisd(rpy_rad.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy_rad.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy_rad.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// Body angular velocity of R = Rz(yaw) Ry(pitch) Rx(roll) from the Euler angle rates (R^T dR/dt = hat(omega)).
Eigen::Vector3d omega_body_from_rpy_rates(const Eigen::Vector3d& rpy_rad, const Eigen::Vector3d& rpy_rate) {
  const double sr = std::sin(rpy_rad.x()), cr = std::cos(rpy_rad.x());
  const double sp = std::sin(rpy_rad.y()), cp = std::cos(rpy_rad.y());
  const double roll_rate = rpy_rate.x(), pitch_rate = rpy_rate.y(), yaw_rate = rpy_rate.z();
  return {roll_rate - sp * yaw_rate,
          cr * pitch_rate + sr * cp * yaw_rate,
          -sr * pitch_rate + cr * cp * yaw_rate};
}

// Pose of a knot with every derivative zero (the trajectory before its start and after its end).
SmoothTrajectory::State held_state(const TimedWaypoint& knot) {
  SmoothTrajectory::State state;
  state.T_world_body.linear() = rotation_from_rpy(knot.rpy_rad);
  state.T_world_body.translation() = knot.p_world;
  return state;
}

}  // namespace

SmoothTrajectory::SmoothTrajectory(std::vector<TimedWaypoint> knots) : knots_(std::move(knots)) {
  validate_knots(knots_);
  unwrap_angles(&knots_);
  std::vector<double> t_s;
  std::vector<Vector6d> values;
  for (const TimedWaypoint& knot : knots_) {
    t_s.push_back(core::ns_to_seconds(knot.t_ns - knots_.front().t_ns));
    values.push_back(knot_values(knot));
  }
  second_derivatives_ = clamped_spline_second_derivatives(t_s, values);
}

core::TimeNs SmoothTrajectory::start_ns() const { return knots_.front().t_ns; }
core::TimeNs SmoothTrajectory::end_ns() const { return knots_.back().t_ns; }

SmoothTrajectory::State SmoothTrajectory::evaluate(core::TimeNs t_ns) const {
  if (t_ns < start_ns()) return held_state(knots_.front());
  if (t_ns > end_ns()) return held_state(knots_.back());
  // Segment i with t_i <= t <= t_{i+1}; the last knot belongs to the last segment.
  const auto after = std::upper_bound(knots_.begin(), knots_.end(), t_ns,
                                      [](core::TimeNs t, const TimedWaypoint& knot) { return t < knot.t_ns; });
  const std::size_t i = std::min(static_cast<std::size_t>(after - knots_.begin()) - 1, knots_.size() - 2);
  const double h = core::ns_to_seconds(knots_[i + 1].t_ns - knots_[i].t_ns);
  const double b = core::ns_to_seconds(t_ns - knots_[i].t_ns) / h;
  const double a = 1.0 - b;
  const Vector6d y0 = knot_values(knots_[i]), y1 = knot_values(knots_[i + 1]);
  const Vector6d& m0 = second_derivatives_[i];
  const Vector6d& m1 = second_derivatives_[i + 1];
  // Cubic spline on [t_i, t_{i+1}] in the weights a = (t_{i+1} - t) / h, b = 1 - a (Numerical Recipes 3.3).
  const Vector6d y = a * y0 + b * y1 + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * (h * h / 6.0);
  const Vector6d dy = (y1 - y0) / h + ((1.0 - 3.0 * a * a) * m0 + (3.0 * b * b - 1.0) * m1) * (h / 6.0);
  const Vector6d ddy = a * m0 + b * m1;

  State state;
  state.T_world_body.linear() = rotation_from_rpy(y.tail<3>());
  state.T_world_body.translation() = y.head<3>();
  state.v_world_mps = dy.head<3>();
  state.a_world_mps2 = ddy.head<3>();
  state.omega_body_radps = omega_body_from_rpy_rates(y.tail<3>(), dy.tail<3>());
  return state;
}

PurePursuit::PurePursuit(const PurePursuitConfig& config) : config_(config) {
  if (!(config.lookahead_m > 0.0) || !(config.max_accel_mps2 > 0.0) || !(config.goal_tolerance_m > 0.0) ||
      !(config.max_speed_mps >= 0.0) || !(config.max_yaw_rate_radps >= 0.0)) {
    throw std::invalid_argument(
        "PurePursuit: lookahead_m, max_accel_mps2 and goal_tolerance_m must be positive, max_speed_mps and "
        "max_yaw_rate_radps non-negative");
  }
}

void PurePursuit::set_path(std::vector<Eigen::Vector2d> path_xy) {
  for (std::size_t i = 0; i < path_xy.size(); ++i) {
    if (!path_xy[i].allFinite()) {
      throw std::invalid_argument("PurePursuit::set_path: point " + std::to_string(i) + " is not finite");
    }
  }
  path_ = std::move(path_xy);
  rebuild_arc_lengths();
  progress_ = 0;
  anchor_pending_ = !path_.empty();
  done_ = path_.empty();
  if (done_) v_last_ = 0.0;
}

void PurePursuit::rebuild_arc_lengths() {
  cumulative_m_.assign(path_.size(), 0.0);
  for (std::size_t i = 1; i < path_.size(); ++i) {
    cumulative_m_[i] = cumulative_m_[i - 1] + (path_[i] - path_[i - 1]).norm();
  }
}

// A new path starts where the robot is: without this first leg, a robot far from the path's first
// point would measure its progress against the whole path and could skip ahead along a loop.
void PurePursuit::anchor_path_at(const Eigen::Vector2d& p_xy) {
  anchor_pending_ = false;
  if ((path_.front() - p_xy).norm() <= config_.goal_tolerance_m) return;
  path_.insert(path_.begin(), p_xy);
  rebuild_arc_lengths();
}

PurePursuit::Projection PurePursuit::project_on_segment(std::size_t segment, const Eigen::Vector2d& p_xy) const {
  Projection projection;
  projection.segment = segment;
  if (segment + 1 >= path_.size()) {  // a one-point path: the point itself
    projection.distance_m = (p_xy - path_[segment]).norm();
    return projection;
  }
  const Eigen::Vector2d a = path_[segment];
  const Eigen::Vector2d ab = path_[segment + 1] - a;
  const double length_sq = ab.squaredNorm();
  projection.s = length_sq > 0.0 ? std::clamp((p_xy - a).dot(ab) / length_sq, 0.0, 1.0) : 0.0;
  projection.distance_m = (p_xy - (a + projection.s * ab)).norm();
  return projection;
}

// Moves the progress index to the nearest segment within a window of path ahead. The window (arc length
// up to the current distance from the path, capped, plus two lookaheads) keeps a path that comes back
// near itself, such as a closed loop, from being skipped; progress never goes back.
PurePursuit::Projection PurePursuit::advance_progress(const Eigen::Vector2d& p_xy) {
  Projection best = project_on_segment(progress_, p_xy);
  const double here_m = arc_length_m(best);
  const double window_m = std::min(best.distance_m, 2.0 * config_.lookahead_m) + 2.0 * config_.lookahead_m;
  for (std::size_t i = progress_ + 1; i + 1 < path_.size(); ++i) {
    if (cumulative_m_[i] - here_m > window_m) break;
    const Projection candidate = project_on_segment(i, p_xy);
    if (candidate.distance_m < best.distance_m) best = candidate;
  }
  progress_ = best.segment;
  return best;
}

double PurePursuit::arc_length_m(const Projection& projection) const {
  if (projection.segment + 1 >= path_.size()) return cumulative_m_[projection.segment];
  const double length = cumulative_m_[projection.segment + 1] - cumulative_m_[projection.segment];
  return cumulative_m_[projection.segment] + projection.s * length;
}

// The point lookahead_m of arc length ahead of the projection, or the goal when the path ends sooner.
Eigen::Vector2d PurePursuit::lookahead_point(const Projection& projection) const {
  const double target_m = arc_length_m(projection) + config_.lookahead_m;
  for (std::size_t i = projection.segment; i + 1 < path_.size(); ++i) {
    if (cumulative_m_[i + 1] < target_m) continue;
    const double length = cumulative_m_[i + 1] - cumulative_m_[i];
    const double s = length > 0.0 ? (target_m - cumulative_m_[i]) / length : 0.0;
    return path_[i] + s * (path_[i + 1] - path_[i]);
  }
  return path_.back();
}

// Largest speed from which the robot, braking at max_accel in steps of dt, stops within distance_m:
// v^2 / (2 a) + v dt / 2 <= distance_m.
double PurePursuit::stopping_speed_mps(double distance_m, double dt_s) const {
  if (distance_m <= 0.0) return 0.0;
  const double a = config_.max_accel_mps2;
  return a * (std::sqrt(0.25 * dt_s * dt_s + 2.0 * distance_m / a) - 0.5 * dt_s);
}

PurePursuit::Command PurePursuit::update(const Eigen::Vector2d& p_xy, double yaw_rad, double dt_s) {
  if (!(dt_s > 0.0) || !std::isfinite(dt_s) || !p_xy.allFinite() || !std::isfinite(yaw_rad)) {
    throw std::invalid_argument("PurePursuit::update: needs a finite pose and a positive finite dt_s");
  }
  if (done_) {
    v_last_ = 0.0;
    return Command{};
  }
  if (anchor_pending_) anchor_path_at(p_xy);
  const Projection here = advance_progress(p_xy);
  const bool on_last_segment = progress_ + 2 >= path_.size();
  const double to_goal_m = (path_.back() - p_xy).norm();
  const double path_left_m = cumulative_m_.back() - arc_length_m(here);
  // Done inside the tolerance once the robot can stop within one step (the acceleration limit holds):
  // on the last segment, or with no more path left than the tolerance (a last segment shorter than
  // the tolerance may never become the nearest one).
  if ((on_last_segment || path_left_m <= config_.goal_tolerance_m) && to_goal_m <= config_.goal_tolerance_m &&
      v_last_ <= config_.max_accel_mps2 * dt_s + 1e-12) {
    done_ = true;
    v_last_ = 0.0;
    return Command{};
  }
  // Brake towards the middle of the goal tolerance, along the path until its last segment, and never
  // from nearer than the goal itself (beside the path's end, less path than distance is left).
  const double remaining_m = on_last_segment ? to_goal_m : std::max(path_left_m, to_goal_m);
  const double brake_m = remaining_m - 0.5 * config_.goal_tolerance_m;
  return steer(p_xy, yaw_rad, lookahead_point(here), stopping_speed_mps(brake_m, dt_s), dt_s);
}

// Pure pursuit (Coulter 1992): the arc through the robot tangent to its heading and through the target
// has curvature 2 sin(alpha) / L, alpha the heading error and L the distance to the target.
PurePursuit::Command PurePursuit::steer(const Eigen::Vector2d& p_xy, double yaw_rad, const Eigen::Vector2d& target,
                                        double v_brake_mps, double dt_s) {
  const Eigen::Vector2d to_target = target - p_xy;
  const double distance_m = to_target.norm();
  const double alpha = distance_m > 1e-9 ? wrap_pi(std::atan2(to_target.y(), to_target.x()) - yaw_rad) : 0.0;
  const double dv = config_.max_accel_mps2 * dt_s;
  const double max_omega = config_.max_yaw_rate_radps;
  Command command;
  command.done = false;
  const double rotate_rad = std::max(config_.rotate_in_place_deg * kPi / 180.0, kMinRotateInPlaceRad);
  if (std::abs(alpha) > rotate_rad) {
    command.v_mps = std::max(0.0, v_last_ - dv);
    command.omega_radps = std::clamp(kRotateGain * alpha, -max_omega, max_omega);
  } else {
    const double curvature = distance_m > 1e-9 ? 2.0 * std::sin(alpha) / distance_m : 0.0;
    double v_want = std::min(config_.max_speed_mps, v_brake_mps);
    if (std::abs(curvature) * v_want > max_omega) v_want = max_omega / std::abs(curvature);
    command.v_mps = std::clamp(v_want, std::max(0.0, v_last_ - dv), v_last_ + dv);
    command.omega_radps = std::clamp(command.v_mps * curvature, -max_omega, max_omega);
  }
  v_last_ = command.v_mps;
  return command;
}

}  // namespace fleetslam::sim
