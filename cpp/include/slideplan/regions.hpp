/// \file regions.hpp
/// Configuration sampleable regions (paper IV-A, IV-B): C = { Gamma~(omega) | omega in Omega } with
/// Omega = (contact points) x { r(alpha, beta0) | alpha in [0, 2 pi) }, the contact depth drawn from
/// the relaxed band [dz_min, dz_max].
#pragma once

#include "slideplan/params.hpp"
#include "slideplan/validity.hpp"

#include <ompl/base/PlannerTerminationCondition.h>
#include <random>
#include <vector>

namespace slideplan
{
    class ContactRegion
    {
    public:
        ContactRegion(std::shared_ptr<const SlidingValidity> validity, const PlannerParams &params);
        virtual ~ContactRegion() = default;

        /// Draw omega, solve Gamma~(omega) from `seed` (then random restarts) and keep the result if it
        /// is a valid sliding state. Returns false if this draw gave no valid configuration.
        /// The IK restarts stop when `ptc` does.
        bool sample(std::mt19937_64 &rng, const Eigen::VectorXd &seed, Eigen::VectorXd &q,
                    const ompl::base::PlannerTerminationCondition &ptc) const;

        /// Solve Gamma~(omega) for a drawn contact frame `target` (IK from `seed`, then restarts until
        /// `ptc`) and keep the result if it is a valid sliding state.
        bool reach(const Eigen::Isometry3d &target, std::mt19937_64 &rng, const Eigen::VectorXd &seed, Eigen::VectorXd &q,
                   const ompl::base::PlannerTerminationCondition &ptc) const;

        /// The contact point (x, y) of a draw; false if this draw found none.
        virtual bool samplePoint(std::mt19937_64 &rng, Eigen::Vector2d &point) const = 0;

    protected:
        /// Asked of every IK solution (so that the restarts look for another posture): none by default.
        virtual bool acceptable(const Eigen::VectorXd &q) const;

        std::shared_ptr<const SlidingValidity> validity_;
        PlannerParams params_;
        double reach_;  ///< upper bound of the distance from the base to the tip: cheap rejection before IK
    };

    /// Eq. 3: contact points from the object's cloud P_o; beyond the paper, only those within
    /// params.contactRadius of the closest distance to the centre of mass, and (params.liftCheck) only
    /// configurations the fingertip can rise from straight up by params.approachHeight above the object,
    /// the line the execution comes down on (a start with a joint at its limit may have none).
    class StartRegion final : public ContactRegion
    {
    public:
        StartRegion(std::shared_ptr<const SlidingValidity> validity, const PlannerParams &params);
        bool samplePoint(std::mt19937_64 &rng, Eigen::Vector2d &point) const override;

    protected:
        bool acceptable(const Eigen::VectorXd &q) const override;

    private:
        std::vector<Eigen::Index> candidates_;  ///< rows of P_o that may be drawn
    };

    /// Eq. 4: contact points P_g from the band between Q and Q contracted inward by d_goal, lifted to z_s.
    class GoalRegion final : public ContactRegion
    {
    public:
        using ContactRegion::ContactRegion;
        /// Uniform in the band: rejection sampling in Q's bounding box on the distance to the boundary,
        /// a bounded number of tries per draw so that a vanishing band ends in a clean timeout.
        bool samplePoint(std::mt19937_64 &rng, Eigen::Vector2d &point) const override;
    };

}  // namespace slideplan
