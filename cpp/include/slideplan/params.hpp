/// \file params.hpp
/// Every parameter of the planner, declared once: parameters() lists each one with its name (as in
/// Python, the scene's [hand] params and the plan JSON), default, bounds, the paper's value and its
/// meaning (params.cpp). PlannerParams holds one value per entry; its constructor sets the defaults,
/// validate() checks the bounds, asPublished() sets the paper's values. Nothing else lists them.
#pragma once

#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace slideplan
{
    /// Which roots the planner grows trees from (paper V-6).
    enum class RootPolicy
    {
        Sampled,  ///< Algorithm 1: start and goal roots sampled from C_s and C_g by Eq. 5 ("slideplan")
        Fixed,    ///< CBiRRT baseline (our reading): one valid start/goal pair drawn first, then connected ("cbirrt")
        FixedStart  ///< CBiRRT2 baseline (our reading): one start drawn first, goals sampled ("cbirrt2")
    };

    /// The values of every parameter of parameters(); each field's meaning is its registry entry's doc.
    struct PlannerParams
    {
        // Constraint and its relaxations (paper IV-C.3, Eqs. 3-4).
        double beta0, deltaBeta, dzMin, dzMax;
        // Root sampling (Eq. 5) and regions (Eq. 4).
        double nStar, dGoal;
        // Pair validation (IV-C.1) and the motion from phi_g to the grasp.
        double uStar, graspLift, approachHeight, graspBackoff, graspStandoff, graspHold;
        double graspTiltTolerance, graspYawTolerance, graspRollTolerance;
        int transferIterations;
        // Constrained extension (CBiRRT [16]).
        double maxJointStep, maxTipStep, projectionTolerance;
        int projectionIterations, rootIkAttempts;
        // Departures from the paper (docs/paper-to-code.md), each with its switch.
        bool screenPairs, graspFlip, graspMap, goalGraspFilter, liftCheck, cacheVerdicts, comSupported, graspModel, supportHull;
        double pairedGoals, contactRadius, comMargin, maxObjectYaw, maxYawRate, shortcutYawWeight;
        int shortcutAttempts;
        // The grasp model (hold_model.hpp).
        double supportMargin, padWidth, padLength, gripForce, objectDensity;

        RootPolicy policy{RootPolicy::Sampled};

        PlannerParams();  ///< every parameter at its registry default

        /// \throws std::invalid_argument "planner parameter NAME ..." naming the first parameter out of its
        ///         bounds, or both parameters of an inconsistent pair. With `given`, only the parameters it
        ///         names are checked, and a pair only when it names both (a config whose other values come later).
        void validate(const std::vector<std::string> *given = nullptr) const;

        /// Algorithm 1 and IsPairValid as published: every parameter whose registry entry has a paper
        /// value takes it (every departure off; section V's Delta_beta, Delta_Z, N*); the parameters the
        /// paper leaves open keep their defaults. The baselines are these parameters with another policy.
        static PlannerParams asPublished();
    };

    /// One parameter of PlannerParams (OMPL's declareParam, with the paper's value beside the default).
    struct ParameterSpec
    {
        using Member = std::variant<double PlannerParams::*, int PlannerParams::*, bool PlannerParams::*>;

        std::string name;       ///< snake_case: Python's PlannerConfig field, [hand] params key, plan JSON key
        Member member;          ///< where the value lives
        std::string unit;       ///< "m", "rad", "rad/m", "m/rad", "" (a count, a share or a flag)
        double defaultValue;    ///< the built-in default (flags: 0 or 1)
        double lower, upper;    ///< bounds of a valid value (flags: 0 and 1)
        bool lowerOpen, upperOpen;  ///< whether a bound itself is excluded
        std::optional<double> paper;  ///< the paper's value; none where the paper leaves the parameter open
        std::string paperSource;  ///< where the paper gives its value, or why it gives none
        bool hand;              ///< a scene's [hand] params may set it (a property of the hand)
        bool graspMap;          ///< the grasp map's probes depend on it (GraspMap::fits)
        std::string doc;        ///< what it means (one paragraph)
        bool verify{false};     ///< a plan's verification reads it, so every plan file must carry it

        const char *kind() const;  ///< "real", "int" or "bool"
        double get(const PlannerParams &params) const;
        void set(PlannerParams &params, double value) const;  ///< rounds to the member's type
        /// "" if `value` lies within the bounds (and is whole for an int, 0 or 1 for a flag), else what is wrong.
        std::string check(double value) const;
    };

    /// Every planner parameter, in a fixed order.
    const std::vector<ParameterSpec> &parameters();

    /// The entry named `name`. \throws std::invalid_argument for an unknown name.
    const ParameterSpec &parameter(const std::string &name);

    RootPolicy rootPolicyFromName(const std::string &name);  ///< "slideplan" | "cbirrt" | "cbirrt2"
    std::string rootPolicyName(RootPolicy policy);

}  // namespace slideplan
