#include "slideplan/timing.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace slideplan
{
    namespace
    {
        constexpr double kMinPathStep = 1e-6;    // s step of a repeated waypoint, so that time still increases strictly
        constexpr int kCornerSubdivisions = 6;   // grid points per waypoint interval at a corner of the path (else 1)
        constexpr double kCornerCurvature = 4.0; // a corner: |q''(s)| at an end above this many times its median
        constexpr double kStraight = 1e-3;       // |q''(s)| (1/rad) below which a path is straight whatever the median
        constexpr double kMaxPathSpeed = 1e6;    // s' where nothing moves: the sets below need a finite bound
        constexpr double kParallel = 1e-12;      // |q_j'(s)| below which joint j does not move along the path

        /// Natural cubic splines through (s_i, y_i), one per column of y.
        class NaturalSpline
        {
        public:
            NaturalSpline(const Eigen::VectorXd &s, const Eigen::MatrixXd &y)
              : s_(s), y_(y), second_(Eigen::MatrixXd::Zero(y.rows(), y.cols()))
            {
                // Second derivatives at the inner knots: a tridiagonal system (Thomas algorithm); zero at the ends.
                const long intervals = s.size() - 1, inner = intervals - 1;
                if (inner < 1)
                    return;
                Eigen::VectorXd lower(inner), diagonal(inner), upper(inner);
                Eigen::MatrixXd rhs(inner, y.cols());
                for (long k = 1; k < intervals; ++k)
                {
                    const double h0 = s(k) - s(k - 1), h1 = s(k + 1) - s(k);
                    lower(k - 1) = h0;
                    diagonal(k - 1) = 2.0 * (h0 + h1);
                    upper(k - 1) = h1;
                    rhs.row(k - 1) = 6.0 * ((y.row(k + 1) - y.row(k)) / h1 - (y.row(k) - y.row(k - 1)) / h0);
                }
                for (long r = 1; r < inner; ++r)
                {
                    const double w = lower(r) / diagonal(r - 1);
                    diagonal(r) -= w * upper(r - 1);
                    rhs.row(r) -= w * rhs.row(r - 1);
                }
                second_.row(inner) = rhs.row(inner - 1) / diagonal(inner - 1);
                for (long r = inner - 2; r >= 0; --r)
                    second_.row(r + 1) = (rhs.row(r) - upper(r) * second_.row(r + 2)) / diagonal(r);
            }

            /// dy/ds at t in interval i ([s_i, s_i+1]).
            Eigen::RowVectorXd first(long i, double t) const
            {
                const double h = s_(i + 1) - s_(i), a = s_(i + 1) - t, b = t - s_(i);
                return -second_.row(i) * (a * a / (2.0 * h)) + second_.row(i + 1) * (b * b / (2.0 * h)) +
                       (y_.row(i + 1) - y_.row(i)) / h - (second_.row(i + 1) - second_.row(i)) * (h / 6.0);
            }

            /// d2y/ds2 at t in interval i.
            Eigen::RowVectorXd second(long i, double t) const
            {
                const double h = s_(i + 1) - s_(i);
                return (second_.row(i) * (s_(i + 1) - t) + second_.row(i + 1) * (t - s_(i))) / h;
            }

            const Eigen::MatrixXd &knotSecond() const { return second_; }

        private:
            Eigen::VectorXd s_;
            Eigen::MatrixXd y_, second_;
        };

        /// u = c + r x: a bound on the path acceleration u = s'' given x = s'^2.
        struct Line
        {
            double c, r;
            double at(double x) const { return c + r * x; }
        };

        /// The bounds on u at one grid point: the joint accelerations (collocated, |q' u + q'' x| <= a_max), and
        /// reaching [low, high] at the next grid point (x + 2 delta u), for the x that satisfy the velocity bound.
        struct Stage
        {
            std::vector<Line> lower, upper;
            double xMax;

            Stage(const Eigen::RowVectorXd &rate, const Eigen::RowVectorXd &curvature, const Eigen::VectorXd &aMax, double xMax)
              : xMax(xMax)
            {
                for (long j = 0; j < rate.size(); ++j)
                {
                    if (std::abs(rate(j)) < kParallel)
                    {
                        if (curvature(j) != 0.0)
                            this->xMax = std::min(this->xMax, aMax(j) / std::abs(curvature(j)));
                        continue;
                    }
                    const double slope = -curvature(j) / rate(j), reach = aMax(j) / std::abs(rate(j));
                    lower.push_back({-reach, slope});
                    upper.push_back({reach, slope});
                }
            }

            void reach(double delta, double low, double high)
            {
                lower.push_back({low / (2.0 * delta), -1.0 / (2.0 * delta)});
                upper.push_back({high / (2.0 * delta), -1.0 / (2.0 * delta)});
            }

            /// The largest lower bound minus the smallest upper bound on u at x (<= 0: some u is admissible).
            double gap(double x, double *lowest = nullptr, double *highest = nullptr) const
            {
                double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
                for (const Line &line : lower)
                    lo = std::max(lo, line.at(x));
                for (const Line &line : upper)
                    hi = std::min(hi, line.at(x));
                if (lowest)
                    *lowest = lo;
                if (highest)
                    *highest = hi;
                return lo - hi;
            }

            bool admits(double x) const
            {
                double lo, hi;
                const double g = gap(x, &lo, &hi);
                return g <= 1e-9 * std::max({1.0, std::abs(lo), std::abs(hi)});
            }

            /// The x in [0, xMax] that admit some u, an interval (the gap is convex in x); false if empty.
            /// Its ends are where a lower and an upper bound meet, or the ends of [0, xMax]: a 2-D linear program
            /// solved by trying those candidates.
            bool admissible(double &low, double &high) const
            {
                std::vector<double> candidates{0.0, xMax};
                for (const Line &l : lower)
                    for (const Line &u : upper)
                        if (l.r != u.r)
                        {
                            const double x = (u.c - l.c) / (l.r - u.r);
                            if (x > 0.0 && x < xMax)
                                candidates.push_back(x);
                        }
                low = std::numeric_limits<double>::infinity();
                high = -low;
                for (const double x : candidates)
                    if (admits(x))
                    {
                        low = std::min(low, x);
                        high = std::max(high, x);
                    }
                return low <= high;
            }
        };

        void requirePositive(const Eigen::VectorXd &values, long size, const char *name)
        {
            if (values.size() != size)
                throw std::invalid_argument(std::string(name) + ": expected " + std::to_string(size) + " values (one per joint), got " +
                                            std::to_string(values.size()));
            if (!(values.array().isFinite().all() && (values.array() > 0.0).all()))
                throw std::invalid_argument(std::string(name) + ": every limit must be a finite number > 0");
        }

        double median(std::vector<double> values)
        {
            const std::size_t middle = values.size() / 2;
            std::nth_element(values.begin(), values.begin() + static_cast<long>(middle), values.end());
            if (values.size() % 2)
                return values[middle];
            const double upper = values[middle];
            return 0.5 * (upper + *std::max_element(values.begin(), values.begin() + static_cast<long>(middle)));
        }

        /// The uniform slow-down c >= 1 after which every limit holds at and between waypoints: the reported
        /// velocities and accelerations, finite differences of positions (velocity) and of velocities
        /// (acceleration), second differences of positions (acceleration, from rest at the ends), and the
        /// fingertip's mean speed over capped intervals. Slowing time by c divides velocities by c and
        /// accelerations by c^2.
        double stretchFactor(const Eigen::MatrixXd &path, const Eigen::MatrixXd &tips, const std::vector<bool> &capped,
                             const Eigen::VectorXd &times, const Eigen::MatrixXd &velocities,
                             const Eigen::MatrixXd &accelerations, const TimingLimits &limits)
        {
            const long count = path.rows(), dof = path.cols();
            const Eigen::ArrayXd vMax = limits.jointVelocity.array(), aMax = limits.jointAcceleration.array();
            double linear = 0.0, quadratic = 0.0;
            for (long i = 0; i < count; ++i)
            {
                linear = std::max(linear, (velocities.row(i).transpose().array().abs() / vMax).maxCoeff());
                quadratic = std::max(quadratic, (accelerations.row(i).transpose().array().abs() / aMax).maxCoeff());
            }
            Eigen::MatrixXd meanVelocity(count + 1, dof);  // rest before and after
            meanVelocity.row(0).setZero();
            meanVelocity.row(count).setZero();
            for (long i = 0; i + 1 < count; ++i)
            {
                const double dt = times(i + 1) - times(i);
                meanVelocity.row(i + 1) = (path.row(i + 1) - path.row(i)) / dt;
                linear = std::max(linear, (meanVelocity.row(i + 1).transpose().array().abs() / vMax).maxCoeff());
                quadratic = std::max(quadratic, ((velocities.row(i + 1) - velocities.row(i)).transpose().array().abs() / dt / aMax).maxCoeff());
                if (capped[i] || capped[i + 1])
                    linear = std::max(linear, (tips.row(i + 1) - tips.row(i)).norm() / dt / limits.fingertipSpeed);
            }
            for (long i = 0; i < count; ++i)
            {
                // From rest, q1 - q0 = a dt^2 / 2: the span to the first mean velocity is dt / 2.
                const double before = i > 0 ? times(i) - times(i - 1) : times(1) - times(0);
                const double after = i + 1 < count ? times(i + 1) - times(i) : times(i) - times(i - 1);
                double span = 0.5 * (before + after);
                if (i == 0 || i + 1 == count)
                    span = 0.5 * (i == 0 ? after : before);
                quadratic = std::max(quadratic, ((meanVelocity.row(i + 1) - meanVelocity.row(i)).transpose().array().abs() / span / aMax).maxCoeff());
            }
            return std::max({1.0, linear, std::sqrt(quadratic)});
        }
    }  // namespace

    TimedPath timePath(const Eigen::MatrixXd &path, const Eigen::MatrixXd &tips, const std::vector<bool> &capped,
                       const TimingLimits &limits)
    {
        const long count = path.rows(), dof = path.cols();
        if (tips.rows() != count || tips.cols() != 3 || static_cast<long>(capped.size()) != count)
            throw std::invalid_argument("timing: expected one fingertip position (x, y, z) and one cap flag per waypoint");
        if (!path.allFinite() || !tips.allFinite())
            throw std::invalid_argument("timing: the path and the fingertip positions must be finite");
        requirePositive(limits.jointVelocity, dof, "joint_velocity");
        requirePositive(limits.jointAcceleration, dof, "joint_acceleration");
        if (!(std::isfinite(limits.fingertipSpeed) && limits.fingertipSpeed > 0.0))
            throw std::invalid_argument("fingertip_speed: must be a finite number > 0");
        TimedPath timed{Eigen::VectorXd::Zero(count), Eigen::MatrixXd::Zero(count, dof), Eigen::MatrixXd::Zero(count, dof)};
        if (count < 2)
            return timed;

        // Path parameter: joint-space arc length, so that |dq/ds| is about 1 everywhere.
        Eigen::VectorXd waypointS(count);
        waypointS(0) = 0.0;
        for (long i = 1; i < count; ++i)
            waypointS(i) = waypointS(i - 1) + std::max((path.row(i) - path.row(i - 1)).norm(), kMinPathStep);
        const NaturalSpline joints(waypointS, path), fingertip(waypointS, tips);

        // Grid: the waypoints, and more at corners (the approach's straight pieces meet at corners), where the
        // direction changes between waypoints faster than the waypoints alone would see.
        std::vector<double> curvature(count);
        for (long i = 0; i < count; ++i)
            curvature[i] = joints.knotSecond().row(i).norm();
        const double cornerCurvature = std::max(kCornerCurvature * median(curvature), kStraight);
        std::vector<double> grid;
        std::vector<long> interval, atWaypoint;
        std::vector<bool> gridCapped;
        for (long i = 0; i + 1 < count; ++i)
        {
            const int pieces = count == 2 ? 2  // rest to rest needs a grid point in between
                               : std::max(curvature[i], curvature[i + 1]) > cornerCurvature ? kCornerSubdivisions
                                                                                             : 1;
            atWaypoint.push_back(static_cast<long>(grid.size()));
            for (int k = 0; k < pieces; ++k)
            {
                grid.push_back(waypointS(i) + (waypointS(i + 1) - waypointS(i)) * k / pieces);
                interval.push_back(i);
                gridCapped.push_back(capped[i] || capped[i + 1]);
            }
        }
        atWaypoint.push_back(static_cast<long>(grid.size()));
        grid.push_back(waypointS(count - 1));
        interval.push_back(count - 2);
        gridCapped.push_back(capped[count - 1]);

        // Each grid point's bounds: the velocity limits bound x = s'^2, the acceleration limits u given x.
        const long last = static_cast<long>(grid.size()) - 1;
        std::vector<Stage> stages;
        stages.reserve(grid.size());
        for (long g = 0; g <= last; ++g)
        {
            const Eigen::RowVectorXd rate = joints.first(interval[g], grid[g]);
            double bound = kMaxPathSpeed;
            for (long j = 0; j < dof; ++j)
                if (std::abs(rate(j)) > 0.0)
                    bound = std::min(bound, limits.jointVelocity(j) / std::abs(rate(j)));
            const double tipRate = fingertip.first(interval[g], grid[g]).norm();
            if (gridCapped[g] && tipRate > 0.0)
                bound = std::min(bound, limits.fingertipSpeed / tipRate);
            stages.emplace_back(rate, joints.second(interval[g], grid[g]), limits.jointAcceleration, bound * bound);
        }

        // Backward pass: the x at each grid point from which rest at the end can still be reached.
        std::vector<double> low(grid.size(), 0.0), high(grid.size(), 0.0);
        const auto fail = [] { return std::runtime_error("no rest-to-rest time parameterization of this path exists under these limits"); };
        for (long g = last - 1; g >= 0; --g)
        {
            stages[g].reach(grid[g + 1] - grid[g], low[g + 1], high[g + 1]);
            if (!stages[g].admissible(low[g], high[g]))
                throw fail();
        }
        if (low[0] > 0.0)
            throw fail();

        // Forward pass: from rest, the largest admissible path acceleration at each step.
        std::vector<double> x(grid.size(), 0.0), u(grid.size() - 1, 0.0);
        for (long g = 0; g < last; ++g)
        {
            const double delta = grid[g + 1] - grid[g];
            double lowest, highest;
            stages[g].gap(x[g], &lowest, &highest);
            x[g + 1] = std::clamp(x[g] + 2.0 * delta * highest, low[g + 1], high[g + 1]);
            u[g] = (x[g + 1] - x[g]) / (2.0 * delta);
        }
        x[last] = 0.0;
        std::vector<double> speed(grid.size()), gridTime(grid.size(), 0.0);
        for (long g = 0; g <= last; ++g)
            speed[g] = std::sqrt(std::max(x[g], 0.0));
        for (long g = 0; g < last; ++g)
        {
            const double sum = speed[g] + speed[g + 1];
            if (!(sum > 0.0))
                throw fail();  // the profile stops inside the path
            gridTime[g + 1] = gridTime[g] + 2.0 * (grid[g + 1] - grid[g]) / sum;
        }

        for (long i = 0; i < count; ++i)
        {
            const long g = atWaypoint[i], piece = std::min(i, count - 2);
            const double rate = speed[g], accel = u[std::min(g, last - 1)];  // the interval that starts there
            timed.timeFromStart(i) = gridTime[g];
            const Eigen::RowVectorXd first = joints.first(piece, waypointS(i)), second = joints.second(piece, waypointS(i));
            timed.velocities.row(i) = first * rate;
            timed.accelerations.row(i) = first * accel + second * (rate * rate);
        }
        timed.velocities.row(0).setZero();
        timed.velocities.row(count - 1).setZero();
        const double scale = stretchFactor(path, tips, capped, timed.timeFromStart, timed.velocities, timed.accelerations, limits);
        timed.timeFromStart *= scale;
        timed.velocities /= scale;
        timed.accelerations /= scale * scale;
        return timed;
    }

    PlanTiming timePlan(const RobotModel &robot, const Eigen::MatrixXd &trajectory, const Eigen::MatrixXd &trajectoryTips,
                        const Eigen::MatrixXd &approach, double objectTopZ, const TimingLimits &limits)
    {
        const long dof = static_cast<long>(robot.dof());
        if (trajectory.cols() != dof || approach.cols() != dof)
            throw std::invalid_argument("timing: expected configurations of " + std::to_string(dof) + " joints");
        Eigen::MatrixXd approachTips(approach.rows(), 3);
        std::vector<bool> approachCapped(approach.rows());
        for (long i = 0; i < approach.rows(); ++i)
        {
            approachTips.row(i) = robot.fk(approach.row(i).transpose()).translation().transpose();
            approachCapped[i] = approachTips(i, 2) < objectTopZ + kNearTableM;
        }
        const auto named = [](const char *segment, auto &&time) {
            try
            {
                return time();
            }
            catch (const std::runtime_error &error)
            {
                throw std::runtime_error(std::string(segment) + ": " + error.what());
            }
        };
        return {named("trajectory", [&] { return timePath(trajectory, trajectoryTips, std::vector<bool>(trajectory.rows(), true), limits); }),
                named("approach", [&] { return timePath(approach, approachTips, approachCapped, limits); })};
    }
}  // namespace slideplan
