/// \file constraint.hpp
/// The relaxed sliding constraint (paper IV-C.3) as an OMPL constraint on the joint space: three
/// scalar rows, x, y and yaw of the contact frame left free.
///   depth:  z_F in [z_s - dz_max, z_s - dz_min]                     (dead zone, Delta_Z)
///   roll:   X_F . n_up = 0                                           (contact line in the surface)
///   pitch:  sin(beta) = -Z_F . n_up in sin([beta0 - dbeta, beta0 + dbeta])   (dead zone, Delta_beta)
#pragma once

#include "slideplan/params.hpp"
#include "slideplan/robot_model.hpp"

#include <ompl/base/Constraint.h>

namespace slideplan
{
    class SlidingConstraint : public ompl::base::Constraint
    {
    public:
        SlidingConstraint(std::shared_ptr<const RobotModel> robot, double surfaceZ, const PlannerParams &params);

        /// Residual of the three rows; zero inside the relaxation bands.
        void function(const Eigen::Ref<const Eigen::VectorXd> &q, Eigen::Ref<Eigen::VectorXd> out) const override;
        void jacobian(const Eigen::Ref<const Eigen::VectorXd> &q, Eigen::Ref<Eigen::MatrixXd> out) const override;

        /// Newton steps with a damped pseudo-inverse of the 3 x n task Jacobian, aiming slightly inside
        /// the bands so the result does not sit on their edge; joint limits are enforced by clamping.
        /// Replaces OMPL's SVD-based projection (docs/design.md 7, 8).
        bool project(Eigen::Ref<Eigen::VectorXd> q) const override;

        /// project(), also returning Gamma(q) of the projected state (computed on the way).
        bool projectWithTip(Eigen::Ref<Eigen::VectorXd> q, Eigen::Isometry3d &tip) const;

        /// Residual of a fingertip pose (no FK): the same rows as function().
        Eigen::Vector3d residual(const Eigen::Isometry3d &tip, double margin = 0.0) const;
        bool satisfied(const Eigen::Isometry3d &tip) const;


    private:
        using TaskJacobian = Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::ColMajor, 3, kMaxJoints>;
        TaskJacobian taskJacobian(const JointsRef &q, const Eigen::Isometry3d &tip,
                                                              const Eigen::Vector3d &residual) const;
        std::shared_ptr<const RobotModel> robot_;
        double zLow_, zHigh_;          ///< z_F band: [z_s - dz_max, z_s - dz_min]
        double sinLow_, sinHigh_;      ///< sin(beta) band
        double margin_;                ///< projection aims this far inside each band
        int iterations_;
    };

}  // namespace slideplan
