#include "slideplan/constraint.hpp"

#include <algorithm>
#include <cmath>

namespace slideplan
{
    namespace
    {
        /// Distance of `value` outside [low, high] (signed), zero inside: the dead-zone rows.
        double outside(double value, double low, double high)
        {
            return value - std::clamp(value, low, high);
        }
    }  // namespace

    SlidingConstraint::SlidingConstraint(std::shared_ptr<const RobotModel> robot, double surfaceZ,
                                         const PlannerParams &params)
      : ompl::base::Constraint(robot->dof(), 3, params.projectionTolerance)
      , robot_(std::move(robot))
      , zLow_(surfaceZ - params.dzMax)
      , zHigh_(surfaceZ - params.dzMin)
      , sinLow_(std::sin(std::max(params.beta0 - params.deltaBeta, -M_PI / 2)))
      , sinHigh_(std::sin(std::min(params.beta0 + params.deltaBeta, M_PI / 2)))
      // Aim a quarter of the narrower band inside it, and never further than the tolerance.
      , margin_(std::min({params.projectionTolerance, 0.25 * (zHigh_ - zLow_), 0.25 * (sinHigh_ - sinLow_)}))
      , iterations_(params.projectionIterations)
    {
    }

    Eigen::Vector3d SlidingConstraint::residual(const Eigen::Isometry3d &tip, double margin) const
    {
        const Eigen::Matrix3d &r = tip.linear();
        return {outside(tip.translation().z(), zLow_ + margin, zHigh_ - margin), r(2, 0),
                outside(-r(2, 2), sinLow_ + margin, sinHigh_ - margin)};
    }

    bool SlidingConstraint::satisfied(const Eigen::Isometry3d &tip) const
    {
        return residual(tip).cwiseAbs().maxCoeff() <= tolerance_;
    }

    SlidingConstraint::TaskJacobian SlidingConstraint::taskJacobian(const JointsRef &q,
                                                                             const Eigen::Isometry3d &tip,
                                                                             const Eigen::Vector3d &residual) const
    {
        const Jacobian jacobian = robot_->jacobian(q);
        const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
        const Eigen::Vector3d xAxis = tip.linear().col(0), zAxis = tip.linear().col(2);
        TaskJacobian rows(3, q.size());
        // Inside a dead zone the row is flat: a zero row keeps the solve from pulling towards the band edge.
        if (residual(0) != 0.0)
            rows.row(0) = jacobian.row(2);
        else
            rows.row(0).setZero();
        rows.row(1) = xAxis.cross(up).transpose() * jacobian.bottomRows<3>();  // d(X_F.z) = w . (X_F x up)
        if (residual(2) != 0.0)
            rows.row(2) = -zAxis.cross(up).transpose() * jacobian.bottomRows<3>();  // d(-Z_F.z)
        else
            rows.row(2).setZero();
        return rows;
    }

    void SlidingConstraint::function(const Eigen::Ref<const Eigen::VectorXd> &q, Eigen::Ref<Eigen::VectorXd> out) const
    {
        out = residual(robot_->fk(q));
    }

    void SlidingConstraint::jacobian(const Eigen::Ref<const Eigen::VectorXd> &q, Eigen::Ref<Eigen::MatrixXd> out) const
    {
        const Eigen::Isometry3d tip = robot_->fk(q);
        out = taskJacobian(q, tip, residual(tip));
    }

    bool SlidingConstraint::project(Eigen::Ref<Eigen::VectorXd> q) const
    {
        Eigen::Isometry3d tip;
        return projectWithTip(q, tip);
    }

    bool SlidingConstraint::projectWithTip(Eigen::Ref<Eigen::VectorXd> q, Eigen::Isometry3d &tip) const
    {
        JointVector joints = q;
        constexpr double damping = 1e-6;
        for (int iteration = 0; iteration <= iterations_; ++iteration)
        {
            tip = robot_->fk(joints);
            if (satisfied(tip))
            {
                q = joints;
                return true;
            }
            if (iteration == iterations_)
                break;
            const Eigen::Vector3d error = residual(tip, margin_);
            const TaskJacobian rows = taskJacobian(joints, tip, error);
            const Eigen::Matrix3d gram = rows * rows.transpose() + damping * Eigen::Matrix3d::Identity();
            joints -= rows.transpose() * gram.ldlt().solve(error);
            joints = joints.cwiseMax(robot_->lowerLimits()).cwiseMin(robot_->upperLimits());
        }
        return false;
    }

}  // namespace slideplan
