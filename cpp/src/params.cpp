#include "slideplan/params.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <type_traits>

namespace slideplan
{
    namespace
    {
        constexpr double inf = std::numeric_limits<double>::infinity();
        constexpr bool open = true, closed = false;
        const std::optional<double> leftOpen;  // the paper gives no value

        ParameterSpec real(std::string name, double PlannerParams::*member, std::string unit, double value, double lower,
                           bool lowerOpen, double upper, bool upperOpen, std::optional<double> paper, std::string paperSource,
                           bool hand, bool graspMap, std::string doc)
        {
            return {std::move(name), member, std::move(unit), value, lower, upper, lowerOpen, upperOpen, paper,
                    std::move(paperSource), hand, graspMap, std::move(doc)};
        }

        ParameterSpec count(std::string name, int PlannerParams::*member, int value, int lower, std::optional<double> paper,
                            std::string paperSource, std::string doc)
        {
            return {std::move(name), member, "", double(value), double(lower), double(std::numeric_limits<int>::max()), false,
                    false, paper, std::move(paperSource), false, false, std::move(doc)};
        }

        ParameterSpec flag(std::string name, bool PlannerParams::*member, bool value, std::optional<double> paper,
                           std::string paperSource, bool hand, bool graspMap, std::string doc)
        {
            return {std::move(name), member, "", value ? 1.0 : 0.0, 0.0, 1.0, false, false, paper, std::move(paperSource),
                    hand, graspMap, std::move(doc)};
        }

        const std::string beyond = "beyond the paper: off (the paper has no such rule)";

        std::vector<ParameterSpec> declare()
        {
            using P = PlannerParams;
            return {
                // Constraint and its relaxations (IV-C.3, Eqs. 3-4).
                real("beta0", &P::beta0, "rad", 1.0, 0.0, open, M_PI / 2, closed, leftOpen,
                     "open: Eq. 3's beta_0 is the user's (the hand's)", true, false,
                     "Contact pitch beta_0 of Eqs. 3-4: the T42's fingertip pad presses at about 57 deg."),
                real("delta_beta", &P::deltaBeta, "rad", 0.1, 0.0, closed, M_PI / 2, open, 0.1,
                     "V: \"we fix it to be 0.1 rad\"", true, false,
                     "Pitch relaxation Delta_beta: the pitch may vary in [beta0 - delta_beta, beta0 + delta_beta]; "
                     "must be < beta0."),
                real("dz_min", &P::dzMin, "m", 0.005, 0.0, closed, inf, open, 0.005, "V-5: Delta_Z^- = 0.5 cm", true, false,
                     "Delta_Z^-: the contact lies at least this far below the object's top."),
                real("dz_max", &P::dzMax, "m", 0.025, 0.0, closed, inf, open, 0.025,
                     "Fig. 10 caption: Delta_Z = [0.5, 2.5] cm", true, false,
                     "Delta_Z^+: the contact lies at most this far below the object's top; dz_max - dz_min is the "
                     "reconfiguration range Delta_Z^*; must be >= dz_min."),
                // Root sampling (Eq. 5) and regions (Eq. 4).
                real("n_star", &P::nStar, "", 100.0, 0.0, open, inf, open, 100.0, "V-7: best of the five values tried",
                     false, false, "N* of Eq. 5: how conservatively new roots are added."),
                real("d_goal", &P::dGoal, "m", 0.05, 0.0, open, inf, open, leftOpen, "open: Eq. 4's band width is not given",
                     true, false, "Width of the goal band P_g inside the table edges (Eq. 4)."),
                // Pair validation (IV-C.1) and the motion to the grasp.
                real("u_star", &P::uStar, "m", 0.02, 0.0, open, inf, open, leftOpen,
                     "open: IV-C.1's minimum contact size is the hand's", true, true,
                     "Minimum overhang u* for a grasp: the T42's minimum contact size."),
                real("grasp_lift", &P::graspLift, "m", 0.05, 0.0, open, inf, open, leftOpen,
                     "open: the paper does not say how the hand moves from phi_g to H_g", true, true,
                     "The fingertip rises this far above the object's top before the transfer to the grasp; the "
                     "grasp's own lift check lifts H_g as far."),
                real("approach_height", &P::approachHeight, "m", 0.03, 0.0, open, inf, open, leftOpen,
                     "open: the paper does not say how the hand comes onto the first contact", false, false,
                     "The fingertip comes down onto the first contact from this far above the object's top, "
                     "straight; with lift_check a start root counts only if that line is reachable from it."),
                real("grasp_backoff", &P::graspBackoff, "m", 0.06, 0.0, closed, inf, open, leftOpen,
                     "open: the paper does not say how the hand moves from phi_g to H_g", true, false,
                     "Pre-grasp offset along the approach axis: the last motion is a straight approach."),
                real("grasp_standoff", &P::graspStandoff, "m", 0.0, 0.0, closed, inf, open, 0.0, beyond + ": H_g at the "
                     "centroid of P_out, u >= u*", true, true,
                     "Beyond the paper: the free length the hand needs beyond H_g towards the table (fingers that reach "
                     "past the grasp frame). H_g moves outward to at least this far beyond the edge, and the overhang "
                     "held, u - max(0, d_g - grasp_standoff), must reach u*. Hand-specific."),
                real("grasp_hold", &P::graspHold, "m", 0.01, 0.0, closed, inf, open, 0.0, beyond + ": H_g at the centroid of P_out",
                     true, false,
                     "Beyond the paper: the length of object the fingers must close on. Where the strip this wide "
                     "across the approach at H_g holds less than this of the object (within the fingers' reach), H_g "
                     "slides along the edge to the nearest strip that does; with none the pose is not graspable."),
                real("grasp_tilt_tolerance", &P::graspTiltTolerance, "rad", 0.0, 0.0, closed, M_PI, closed, 0.0,
                     beyond + ": H_g exactly", true, true,
                     "Beyond the paper: how far the hand may turn about H_g's x (along the table edge) at the grasp."),
                real("grasp_yaw_tolerance", &P::graspYawTolerance, "rad", 0.0, 0.0, closed, M_PI, closed, 0.0,
                     beyond + ": H_g exactly", true, true,
                     "Beyond the paper: how far the hand may turn about H_g's y (the vertical closing axis: the "
                     "approach's heading) at the grasp; a five-joint arm needs it."),
                real("grasp_roll_tolerance", &P::graspRollTolerance, "rad", 0.0, 0.0, closed, M_PI, closed, 0.0,
                     beyond + ": H_g exactly", true, true,
                     "Beyond the paper: how far the hand may turn about H_g's z (the approach axis) at the grasp."),
                count("transfer_iterations", &P::transferIterations, 500, 0, leftOpen,
                      "open: the paper does not say how the hand moves from phi_g to H_g",
                      "RRTConnect iterations per transfer to the pre-grasp when the straight motion is blocked (a "
                      "count, so the plan does not depend on the machine's speed); 0: straight motions only."),
                // Constrained extension (CBiRRT [16]).
                real("max_joint_step", &P::maxJointStep, "rad", 0.02, 1e-3, closed, inf, open, leftOpen,
                     "open: CBiRRT's step size; 0.02 rad is the dense path's bound", false, false,
                     "Largest joint change between tree nodes, and so between waypoints of the dense path."),
                real("max_tip_step", &P::maxTipStep, "m", 0.01, 1e-4, closed, inf, open, leftOpen,
                     "open: CBiRRT's step size; 1 cm is the dense path's bound", false, false,
                     "Largest fingertip displacement between tree nodes."),
                // The verifier allows 1e-3 m / 1e-3 rad off the constraint: a sin residual of 5e-4 stays within it.
                real("projection_tolerance", &P::projectionTolerance, "", 1e-4, 0.0, open, 5e-4, closed, leftOpen,
                     "open: CBiRRT's projection tolerance", false, false,
                     "Residual tolerance of the projection onto the constraint (m of depth, sin of rad)."),
                count("projection_iterations", &P::projectionIterations, 30, 1, leftOpen, "open: CBiRRT's projection",
                      "Newton steps of one projection."),
                count("root_ik_attempts", &P::rootIkAttempts, 3, 1, leftOpen, "open: how Gamma of Eqs. 3-4 is computed",
                      "IK attempts (seed and restarts) per root draw: a draw is cheap to reject."),
                // Departures (docs/paper-to-code.md).
                flag("screen_pairs", &P::screenPairs, true, 0.0, "Algorithm 1's NearestTree", false, false,
                     "Beyond the paper: NearestTree skips trees whose root pair was rejected or fails the cheap part "
                     "of IsPairValid, and goal roots the finger cannot lift off from are not kept."),
                flag("grasp_flip", &P::graspFlip, true, 0.0, beyond + ": H_g as defined", true, true,
                     "Beyond the paper: a grasp may also be made with the hand rolled by pi about its approach axis "
                     "(the same grasp for a hand whose fingers close symmetrically)."),
                flag("grasp_map", &P::graspMap, true, 0.0, beyond + ": a grasp IK for every pair", false, false,
                     "Beyond the paper: remember the 1 cm table-edge stretches where no side grasp was reachable, and "
                     "reject and screen pairs whose grasp falls there without another IK."),
                real("paired_goals", &P::pairedGoals, "", 0.9, 0.0, closed, 1.0, closed, 0.0,
                     "Algorithm 1: every goal root drawn from C_g", false, false,
                     "Beyond the paper: the share of goal-root draws made for a start root so that Eq. 2 leaves the "
                     "object overhanging an edge with its centre of mass on the table."),
                flag("goal_grasp_filter", &P::goalGraspFilter, true, 0.0, "Algorithm 1: every goal root kept", false, false,
                     "Beyond the paper (with grasp_map): a goal root by an edge stretch without a reachable side grasp "
                     "is kept one time in ten."),
                flag("lift_check", &P::liftCheck, true, 0.0, "IV-C.1, Eq. 3: any IK solution of H_g or of a contact",
                     false, true,
                     "Beyond the paper: a grasp IK solution counts only if H_g raised by grasp_lift is reachable from "
                     "it, and a start root only if the fingertip rises approach_height above the object from it, a "
                     "centimetre at a time as the execution moves."),
                flag("cache_verdicts", &P::cacheVerdicts, true, 0.0, "Algorithm 1: every connection checked", false, false,
                     "Beyond the paper: IsPairValid's verdict is remembered per root pair."),
                real("contact_radius", &P::contactRadius, "m", 0.03, 0.0, closed, inf, open, 0.0, "Eq. 3: the whole cloud",
                     false, false,
                     "Beyond the paper: start contacts are drawn from the cloud points at most this much farther from "
                     "the centre of mass than the closest one (0: the whole cloud)."),
                count("shortcut_attempts", &P::shortcutAttempts, 50, 0, 0.0, "Algorithm 1 returns the tree path",
                      "Beyond the paper: tries to shorten the solved path by constrained walks between two waypoints."),
                real("shortcut_yaw_weight", &P::shortcutYawWeight, "m/rad", 0.05, 0.0, closed, inf, open, leftOpen,
                     "open, and moot in the paper preset: it weighs the shortcut, which the paper has not", false, false,
                     "Beyond the paper: the shortcut keeps a walk that lowers fingertip travel plus this many metres "
                     "per radian of the object's yaw travel."),
                real("com_margin", &P::comMargin, "m", 0.005, 0.0, closed, inf, open, 0.0, "IV-C.1: the CoM inside Q", false,
                     false, "Beyond the paper: the final centre of mass lies at least this far inside the table."),
                flag("support_hull", &P::supportHull, false, 0.0, "IV-C.1: the CoM inside Q", false, false,
                     "Beyond the paper (opt-in): at the final pose the centre of mass lies support_margin inside the convex hull "
                     "of the object's part on the table too (what the table bears: an L's centre of mass may lie inside "
                     "the table and off that part, and the object tips over the edge when the finger lets go)."),
                real("support_margin", &P::supportMargin, "m", 0.0075, 0.0, closed, inf, open, leftOpen,
                     "open, and moot in the paper preset: support_hull is off", false, false,
                     "With support_hull: how far inside the hull of the object's part on the table its centre of mass "
                     "lies at the final pose; calibrated against MuJoCo (docs/results/grasp_model.md)."),
                flag("com_supported", &P::comSupported, true, 0.0, "IV-C.1: the final pose only", false, false,
                     "Beyond the paper: the object's centre of mass stays on the table at every state of the slide."),
                real("max_object_yaw", &P::maxObjectYaw, "rad", 1.0, 0.0, open, inf, open, M_PI, "IV-C.1: any turn", false,
                     false, "Beyond the paper: the largest turn of the object between its start and final pose."),
                real("max_yaw_rate", &P::maxYawRate, "rad/m", 0.0, 0.0, closed, inf, open, 0.0, "the paper: any turn", true,
                     false,
                     "Beyond the paper: the largest turn of the object per metre of fingertip travel in each "
                     "extension step (0: any). Hand-specific: how fast its pad can turn an object."),
                // The grasp model (hold_model.hpp): does the closed hand hold the object up?
                flag("grasp_model", &P::graspModel, false, 0.0, beyond + ": the overhang alone decides", false, false,
                     "Beyond the paper (opt-in): a pair counts only if the closed hand holds the object up against gravity: "
                     "gravity's moment about the pads, the object's weight times the lever from the patch of object "
                     "between them to its centre of mass, is at most grip_force times that patch's length along the "
                     "lever (a soft-finger pinch, hold_model.hpp)."),
                real("pad_width", &P::padWidth, "m", 0.03, 0.0, open, inf, open, leftOpen,
                     "open, and moot in the paper preset: grasp_model is off", true, false,
                     "The grasp model's pads: their width along the table edge (the T42's fingers: 3 cm)."),
                real("pad_length", &P::padLength, "m", 0.045, 0.0, open, inf, open, leftOpen,
                     "open, and moot in the paper preset: grasp_model is off", true, false,
                     "The grasp model's pads: their length along the approach, centred on H_g (the T42's distal "
                     "links: 4.5 cm)."),
                real("grip_force", &P::gripForce, "N", 0.75, 0.0, open, inf, open, leftOpen,
                     "open, and moot in the paper preset: grasp_model is off", true, false,
                     "The grasp model's effective closing force of the pads, calibrated against MuJoCo for the "
                     "T42 (docs/results/grasp_model.md)."),
                real("object_density", &P::objectDensity, "kg/m^3", 1000.0, 0.0, open, inf, open, leftOpen,
                     "open, and moot in the paper preset: grasp_model is off", false, false,
                     "The grasp model's object density: the object weighs this times its thickness and area."),
            };
        }
    }  // namespace

    const std::vector<ParameterSpec> &parameters()
    {
        static const std::vector<ParameterSpec> all = [] {
            std::vector<ParameterSpec> specs = declare();
            // What slideplan.verify reads from a plan's params: every plan file since slideplan.plan/1 carries them.
            for (ParameterSpec &spec : specs)
                for (const char *name : {"beta0", "delta_beta", "dz_min", "dz_max", "u_star", "grasp_lift", "max_joint_step",
                                         "max_tip_step"})
                    spec.verify = spec.verify || spec.name == name;
            return specs;
        }();  // immutable once built (a thread-safe static)
        return all;
    }

    const ParameterSpec &parameter(const std::string &name)
    {
        for (const ParameterSpec &spec : parameters())
            if (spec.name == name)
                return spec;
        throw std::invalid_argument("unknown planner parameter '" + name + "'");
    }

    const char *ParameterSpec::kind() const
    {
        static const char *const kinds[] = {"real", "int", "bool"};
        return kinds[member.index()];
    }

    double ParameterSpec::get(const PlannerParams &params) const
    {
        return std::visit([&](auto field) { return static_cast<double>(params.*field); }, member);
    }

    void ParameterSpec::set(PlannerParams &params, double value) const
    {
        std::visit(
            [&](auto field) {
                using T = std::remove_reference_t<decltype(params.*field)>;
                if constexpr (std::is_same_v<T, double>)
                    params.*field = value;
                else if constexpr (std::is_same_v<T, bool>)
                    params.*field = value != 0.0;
                else
                    params.*field = static_cast<T>(std::llround(value));
            },
            member);
    }

    std::string ParameterSpec::check(double value) const
    {
        std::ostringstream interval;
        interval << (lowerOpen ? "(" : "[") << lower << ", ";
        if (upper >= std::numeric_limits<int>::max())  // inf, or an int's largest value
            interval << "inf)";
        else
            interval << upper << (upperOpen ? ")" : "]");
        const bool inside = std::isfinite(value) && (lowerOpen ? value > lower : value >= lower) &&
                            (upperOpen ? value < upper : value <= upper);
        if (member.index() == 2)
            return value == 0.0 || value == 1.0 ? "" : "must be true or false";
        if (member.index() == 1 && (!inside || value != std::floor(value)))
            return "must be an integer in " + interval.str();
        return inside ? "" : "must lie in " + interval.str() + (unit.empty() ? "" : " " + unit);
    }

    PlannerParams::PlannerParams()
    {
        for (const ParameterSpec &spec : parameters())
            spec.set(*this, spec.defaultValue);
    }

    void PlannerParams::validate(const std::vector<std::string> *given) const
    {
        const auto isGiven = [given](const std::string &name) {
            return !given || std::find(given->begin(), given->end(), name) != given->end();
        };
        for (const ParameterSpec &spec : parameters())
            if (const std::string problem = isGiven(spec.name) ? spec.check(spec.get(*this)) : ""; !problem.empty())
            {
                std::ostringstream message;
                message << "planner parameter " << spec.name << " " << problem << ", got " << spec.get(*this);
                throw std::invalid_argument(message.str());
            }
        // The two pairs: name both, since the user may have set only one of them.
        if (isGiven("delta_beta") && isGiven("beta0") && deltaBeta >= beta0)
        {
            std::ostringstream message;
            message << "planner parameter delta_beta must be < beta0 (the pitch band beta0 +- delta_beta stays above 0): "
                    << "delta_beta = " << deltaBeta << ", beta0 = " << beta0 << "; lower delta_beta or raise beta0";
            throw std::invalid_argument(message.str());
        }
        if (isGiven("dz_max") && isGiven("dz_min") && dzMax < dzMin)
        {
            std::ostringstream message;
            message << "planner parameter dz_max must be >= dz_min (the reconfiguration range dz_max - dz_min cannot be "
                    << "negative): dz_max = " << dzMax << ", dz_min = " << dzMin << "; raise dz_max or lower dz_min";
            throw std::invalid_argument(message.str());
        }
    }

    PlannerParams PlannerParams::asPublished()
    {
        PlannerParams params;
        for (const ParameterSpec &spec : parameters())
            if (spec.paper)
                spec.set(params, *spec.paper);
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
