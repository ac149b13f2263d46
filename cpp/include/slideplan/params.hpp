/// \file params.hpp
/// Every parameter of the planner, declared once. Defaults from the paper where it gives them
/// (section V: Delta_beta = 0.1 rad, Delta_Z^- = 0.5 cm, reconfiguration range 2 cm, N* = 100,
/// 60 s budget); the others are chosen for the WAM + T42 and palm-sized objects (docs/parameters.md).
#pragma once

#include <cmath>
#include <string>

namespace slideplan
{
    /// Which roots the planner grows trees from (paper V-6).
    enum class RootPolicy
    {
        Sampled,  ///< Algorithm 1: start and goal roots sampled from C_s and C_g by Eq. 5 ("slideplan")
        Fixed,    ///< CBiRRT baseline: one valid start/goal pair precomputed, then connected ("cbirrt")
        FixedStart  ///< CBiRRT2 baseline: one start precomputed, goals sampled ("cbirrt2")
    };

    struct PlannerParams
    {
        // Constraint and its relaxations (paper IV-C.3, Eqs. 3-4).
        double beta0{1.0};        ///< contact pitch beta_0 (rad): the T42 fingertip pad pressing at ~57 deg
        double deltaBeta{0.1};    ///< pitch relaxation Delta_beta (rad), paper V
        double dzMin{0.005};      ///< Delta_Z^-: minimum contact depth below z_s (m), paper V-5
        double dzMax{0.025};      ///< Delta_Z^+ = Delta_Z^- + reconfiguration range (2 cm), paper V-5

        // Root sampling (Eq. 5) and regions.
        double nStar{100.0};      ///< N* of Eq. 5, paper V-7
        double dGoal{0.05};       ///< width of the goal band P_g inside the table edges (m), Eq. 4

        // Pair validation (IV-C.1).
        double uStar{0.02};       ///< minimum overhang u* (m): the T42's minimum contact size
        double graspLift{0.05};   ///< fingertip lift before the transfer to the grasp (m)
        double graspBackoff{0.06};  ///< pre-grasp offset along the approach axis (m)
        /// Beyond the paper: the free length the hand needs beyond H_g towards the table along its
        /// approach (m): fingers that reach past the grasp frame (the T42's by 2.3 cm) meet the table's
        /// side when H_g lies nearer the edge than that (21 of 23 failed grasps in issue 9's replay). H_g
        /// moves outward to at least this far beyond the edge, and the overhang held by the hand is
        /// counted from where this free length ends: u - max(0, d_g - s) >= u*. 0 is the paper: H_g at
        /// the centroid of P_out and u >= u*. Hand-specific: set in the scene's [hand] params.
        double graspStandoff{0.0};
        /// Beyond the paper: the length of object the fingers must close on (m). H_g at the centroid of
        /// P_out may hold nothing: a crescent overhanging with both horns has its centroid between them
        /// (15 of 120 closed-loop runs on the crescent closed on air). Where no point of P_out lies
        /// within grasp_hold/2 across the approach from H_g and extending grasp_hold along it (within the
        /// hand's reach, max(grasp_standoff, grasp_hold), from H_g towards the table), H_g slides along
        /// the edge to the nearest place that has such a strip; with none, the pose is not graspable.
        /// 0 is the paper: H_g at the centroid.
        double graspHold{0.01};
        /// Beyond the paper: how far the hand may turn away from H_g's orientation at the grasp (rad),
        /// about H_g's x (along the table edge: a tilt of the approach), y (the closing axis, vertical: the
        /// approach's heading) and z (the approach axis: a roll). An arm with five joints cannot reach
        /// every 6-D grasp pose; a hand that still pinches the overhang when turned a little tolerates
        /// it. 0 is the paper: H_g exactly. Hand-specific: set in the scene's [hand] params.
        double graspTiltTolerance{0.0};
        double graspYawTolerance{0.0};
        double graspRollTolerance{0.0};
        double transferTime{0.2};   ///< RRTConnect budget per transfer when the straight motion fails (s)

        // Constrained extension (CBiRRT [16]).
        double maxJointStep{0.02};     ///< largest joint change between tree nodes (rad); also the path density
        double maxTipStep{0.01};       ///< largest fingertip displacement between tree nodes (m)
        double projectionTolerance{1e-4};  ///< residual tolerance of the projection (m, and sin of rad)
        int projectionIterations{30};
        int rootIkAttempts{3};    ///< IK attempts (seed + restarts) per root sample: cheap rejection

        RootPolicy policy{RootPolicy::Sampled};

        /// Beyond the paper: when connecting, NearestTree skips trees whose root pair was already
        /// rejected or fails the cheap geometric part of IsPairValid (overhang, CoM), and goal roots the
        /// finger cannot lift off from are not kept. False is Algorithm 1's NearestTree.
        bool screenPairs{true};

        /// Beyond the paper: a grasp may also be made with the hand rolled by pi about its approach axis
        /// (H_g's y pointing down), the same grasp for a hand whose fingers close symmetrically.
        bool graspFlip{true};

        /// Beyond the paper: remember, per 1 cm stretch of each table edge, where no side grasp was
        /// reachable, and reject (and screen) pairs whose grasp falls there without another IK.
        bool graspMap{true};

        /// Beyond the paper: the share of goal-root draws made for a randomly chosen start root, so that
        /// Eq. 2 leaves the object overhanging an edge with its centre of mass on the table
        /// (paired_goal.hpp); the rest are drawn from C_g as Algorithm 1 does. 0 is the paper; the
        /// baselines (cbirrt, cbirrt2) always draw as published.
        double pairedGoals{0.9};

        /// Beyond the paper: a goal root by a table-edge stretch where the grasp map found no reachable side
        /// grasp is kept only one time in ten (with graspMap): such roots mostly grow trees whose pairs
        /// fail at the grasp. False keeps every goal root, as Algorithm 1 does.
        bool goalGraspFilter{true};

        /// Beyond the paper: a grasp IK solution counts only if H_g raised by grasp_lift is reachable from
        /// it too (a grasp with a joint at its limit cannot lift the object). False accepts any solution
        /// of H_g, as IV-C.1 does.
        bool liftCheck{true};

        /// Beyond the paper: IsPairValid's verdict is remembered per (start root, goal root) pair, so a
        /// pair that failed (also by a grasp IK that missed by chance) is not checked again when its trees
        /// meet elsewhere. False checks every connection, as Algorithm 1 does. CBiRRT's one pair is
        /// validated before its trees grow, either way.
        bool cacheVerdicts{true};

        /// Beyond the paper: start contacts are drawn from the cloud points at most this much farther
        /// from the centre of mass than the closest point (Eq. 3 restricted): a push far from the
        /// centre of mass turns the object against the finger's torsional friction, and such slides
        /// left Eq. 2 in the physics replay (issue 9). 0: the whole cloud, as the paper does.
        double contactRadius{0.03};

        /// Beyond the paper: attempts to shorten the solved path by constrained walks between two of
        /// its waypoints (same step bounds and checks as extension); 0 returns the tree path as is.
        int shortcutAttempts{50};

        /// Beyond the paper: the final centre of mass must lie at least this far inside Q (m), not just
        /// inside (the paper): an object whose CoM is within a few millimetres of the edge tips over
        /// when the finger lifts (3 of 39 replayed plans fell with 0.7-1.6 mm margins, issue 9). 5 mm
        /// leaves room for the object's last millimetres of slip.
        double comMargin{0.005};

        /// Beyond the paper: a pair is valid only if the object turns by at most this much between its
        /// start and final pose (rad): large turns are what fails in execution (docs/physics-facts.md; of
        /// plans turning the object 150 deg or more, 2 in 13 executed). 1 rad cut the median yaw travel
        /// from 104 to 33 deg at the same planning time (3 tables x 5 objects x 3 poses); pi accepts
        /// every pair, as the paper does.
        double maxObjectYaw{1.0};

        /// Beyond the paper: every extension step may turn the contact frame (and the object) by at most
        /// this much per metre of fingertip travel over the table (rad/m); 0 allows any turn (the paper).
        /// Hand-specific (how fast its pad can turn an object: torsional friction), set in [hand] params.
        /// A hard bound can cut trees apart (they cannot turn on the spot): measured for the T42 only.
        /// Turning on the spot is what fails in execution: in issue 9's replay plans turning more than
        /// 4 deg per cm of fingertip path ended off Eq. 2's pose 3 times in 5, under it 2 in 25. 7 rad/m
        /// (4 deg/cm) cut the p90 of the plans' yaw per cm from 5.8 to 2.3 deg/cm and of their yaw travel
        /// from 373 to 55 deg (square table, 20 plans) at the same planning time.
        double maxYawRate{0.0};

        /// Beyond the paper: the object's centre of mass stays on the table (inside Q) at every state of
        /// the slide, not only at its end (Eq. 2 moves it through every state). The paper checks the final
        /// pose only; a re-plan from an object already at an edge could then swing its centre of mass over
        /// the edge and back, and in MuJoCo the object fell there (closed loop, triangle table).
        bool comSupported{true};

        /// Beyond the paper: the shortcut keeps a walk when it lowers fingertip travel (m) plus this
        /// weight times the object's yaw travel (rad): turning the object in place is what fails in
        /// execution (docs/physics-facts.md), so a radian of yaw costs like this many metres of travel.
        double shortcutYawWeight{0.05};

        /// \throws std::invalid_argument naming the first inconsistent parameter.
        void validate() const;

        /// Algorithm 1 as published: every departure above off (screening, paired goals, the grasp map
        /// and its goal filter, the lift check, verdict caching, the second hand orientation, the
        /// shortcut, the contact radius, the CoM margin, the turn bounds, the grasp standoff) and the
        /// paper's section V values (Delta_beta = 0.1 rad, Delta_Z = [0.5, 2.5] cm, N* = 100). What the
        /// paper leaves open keeps its default: beta0, u*, d_goal, and how the motion from phi_g to H_g is
        /// found (lift, transfer, approach). The baselines are these parameters with another policy.
        static PlannerParams asPublished();
    };

    RootPolicy rootPolicyFromName(const std::string &name);  ///< "slideplan" | "cbirrt" | "cbirrt2"
    std::string rootPolicyName(RootPolicy policy);

}  // namespace slideplan
