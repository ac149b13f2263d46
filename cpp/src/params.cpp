#include "slideplan/params.hpp"

#include <cmath>
#include <stdexcept>
#include <utility>

namespace slideplan
{
    namespace
    {
        void require(bool condition, const std::string &message)
        {
            if (!condition)
                throw std::invalid_argument("planner parameter " + message);
        }
    }  // namespace

    void PlannerParams::validate() const
    {
        const auto finite = [](double value) { return std::isfinite(value); };
        require(finite(beta0) && beta0 > 0.0 && beta0 <= M_PI / 2, "beta0 must lie in (0, pi/2]");
        require(finite(deltaBeta) && deltaBeta >= 0.0 && deltaBeta < beta0, "delta_beta must lie in [0, beta0)");
        require(finite(dzMin) && dzMin >= 0.0, "dz_min must be >= 0");
        require(finite(dzMax) && dzMax >= dzMin, "dz_max must be >= dz_min (the reconfiguration range dz_max - dz_min cannot be negative)");
        require(finite(nStar) && nStar > 0.0, "n_star must be > 0");
        require(finite(dGoal) && dGoal > 0.0, "d_goal must be > 0");
        require(finite(uStar) && uStar > 0.0, "u_star must be > 0");
        require(finite(graspLift) && graspLift > 0.0, "grasp_lift must be > 0");
        require(finite(graspBackoff) && graspBackoff >= 0.0, "grasp_backoff must be >= 0");
        require(finite(graspStandoff) && graspStandoff >= 0.0, "grasp_standoff must be >= 0");
        require(finite(graspHold) && graspHold >= 0.0, "grasp_hold must be >= 0");
        for (const auto &[value, name] : {std::pair{graspTiltTolerance, "grasp_tilt_tolerance"},
                                          std::pair{graspYawTolerance, "grasp_yaw_tolerance"},
                                          std::pair{graspRollTolerance, "grasp_roll_tolerance"}})
            require(finite(value) && value >= 0.0 && value <= M_PI, std::string(name) + " must lie in [0, pi]");
        require(finite(transferTime) && transferTime >= 0.0, "transfer_time must be >= 0");
        // The dense path has a state per step: finer steps than these make paths of millions of states
        // (gigabytes, minutes past the time limit) for no better plan.
        require(finite(maxJointStep) && maxJointStep >= 1e-3, "max_joint_step must be >= 1e-3 rad");
        require(finite(maxTipStep) && maxTipStep >= 1e-4, "max_tip_step must be >= 1e-4 m");
        // Projected states must land inside the slack slideplan.verify allows on the constraint rows (1e-3 m of
        // depth, 1e-3 rad of roll and pitch): a sin residual of 5e-4 is under 1e-3 rad at any pitch up to 60 deg.
        require(finite(projectionTolerance) && projectionTolerance > 0.0 && projectionTolerance <= 5e-4,
                "projection_tolerance must be in (0, 5e-4]: the verifier allows 1e-3 m / 1e-3 rad off the constraint");
        require(projectionIterations > 0, "projection_iterations must be > 0");
        require(rootIkAttempts > 0, "root_ik_attempts must be > 0");
        require(shortcutAttempts >= 0, "shortcut_attempts must be >= 0");
        require(finite(maxObjectYaw) && maxObjectYaw > 0.0, "max_object_yaw must be > 0");
        require(finite(maxYawRate) && maxYawRate >= 0.0, "max_yaw_rate must be >= 0");
        require(finite(comMargin) && comMargin >= 0.0, "com_margin must be >= 0");
        require(finite(contactRadius) && contactRadius >= 0.0, "contact_radius must be >= 0");
        require(finite(pairedGoals) && pairedGoals >= 0.0 && pairedGoals <= 1.0, "paired_goals must be in [0, 1]");
        require(finite(shortcutYawWeight) && shortcutYawWeight >= 0.0, "shortcut_yaw_weight must be >= 0");
    }

    PlannerParams PlannerParams::asPublished()
    {
        PlannerParams params;
        params.deltaBeta = 0.1;
        params.dzMin = 0.005;
        params.dzMax = 0.025;
        params.nStar = 100.0;
        params.graspStandoff = 0.0;
        params.graspHold = 0.0;
        params.graspTiltTolerance = params.graspYawTolerance = params.graspRollTolerance = 0.0;
        params.screenPairs = false;
        params.graspFlip = false;
        params.graspMap = false;
        params.goalGraspFilter = false;
        params.liftCheck = false;
        params.cacheVerdicts = false;
        params.pairedGoals = 0.0;
        params.contactRadius = 0.0;
        params.shortcutAttempts = 0;
        params.comMargin = 0.0;
        params.maxObjectYaw = M_PI;
        params.maxYawRate = 0.0;
        params.comSupported = false;
        return params;
    }

    RootPolicy rootPolicyFromName(const std::string &name)
    {
        if (name == "slideplan")
            return RootPolicy::Sampled;
        if (name == "cbirrt")
            return RootPolicy::Fixed;
        if (name == "cbirrt2")
            return RootPolicy::FixedStart;
        throw std::invalid_argument("unknown planner '" + name + "' (expected slideplan, cbirrt or cbirrt2)");
    }

    std::string rootPolicyName(RootPolicy policy)
    {
        switch (policy)
        {
            case RootPolicy::Sampled:
                return "slideplan";
            case RootPolicy::Fixed:
                return "cbirrt";
            case RootPolicy::FixedStart:
                return "cbirrt2";
        }
        return "unknown";
    }

}  // namespace slideplan
