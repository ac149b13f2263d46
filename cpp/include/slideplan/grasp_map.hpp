/// \file grasp_map.hpp
/// Beyond the paper (params.graspMap): which stretches of the table's edges admit a side grasp H_g
/// (at table height, approaching perpendicular to the edge) that the arm reaches and can then lift.
#pragma once

#include "slideplan/params.hpp"
#include "slideplan/straight_line.hpp"
#include "slideplan/task.hpp"

#include <cmath>
#include <map>
#include <mutex>
#include <vector>
#include <random>
#include <utility>

namespace slideplan
{
    /// H_g at `point` approaching perpendicular to `edge` (into the table), mid-thickness at `z`; y up,
    /// so the straight (+Y) finger is above the object.
    Eigen::Isometry3d sideGraspPose(const Eigen::Vector2d &point, const EdgeQuery &edge, double z);

    /// The grasp IK's options: H_g's orientation within the hand's tolerated rotation (params).
    IkOptions graspIkOptions(const PlannerParams &params);

    /// IK for the grasp frame `grasp` (task.graspLink x task.graspOffset) from `seed`, then random
    /// restarts up to `attempts`, within the tolerated rotation; with params.liftCheck, only a solution from which H_g rises
    /// params.graspLift straight up (straightLine, as the execution lifts): at the edge of the workspace a joint may sit at its limit. `abandonAfter`: as
    /// IkOptions::abandonAfter.
    bool liftableGraspIk(const SlidingTask &task, const PlannerParams &params, const Eigen::Isometry3d &grasp,
                         const Eigen::VectorXd &seed, int attempts, std::mt19937_64 &rng, Eigen::VectorXd &solution,
                         int abandonAfter = 0);

    /// The grasp map: per kStretch of each edge of Q, whether a side grasp just far enough beyond the edge
    /// for u* (params.graspStandoff, u*/2) is reachable and liftable, the hand as given or (params.graspFlip)
    /// rolled by pi. Each stretch is probed once, when first asked, by IK from random restarts seeded by
    /// the stretch itself; one between two unreachable anchor stretches (every kAnchor-th) is not, and
    /// one between anchors with grasps starts from theirs. An answer depends only on the geometry, never
    /// on which plan asked first, so any number of plans (in any threads) share one map and get the
    /// plans they would get alone.
    class GraspMap
    {
    public:
        static constexpr double kStretch = 0.01;  ///< m: grasps this close have the same reachability in practice

        /// The map of a robot's grasp frame (graspLink x graspOffset) on `table`, for objects
        /// `thickness` thick (to the micrometre) under `params`; obstacles do not matter.
        GraspMap(std::shared_ptr<const RobotModel> robot, std::shared_ptr<const SupportSurface> table,
                 std::string graspLink, const Eigen::Isometry3d &graspOffset, double thickness, const PlannerParams &params);

        /// The map of `task`'s robot, table, grasp frame and object thickness.
        GraspMap(const SlidingTask &task, const PlannerParams &params);

        /// Whether a side grasp is reachable on the stretch of `edge.edge` holding `edge.closest`.
        bool reachable(const EdgeQuery &edge) const;

        /// The liftable grasp configuration the probe of that stretch found (a seed for grasps on the
        /// stretch: they lie within a centimetre of it), empty if none is reachable there.
        Eigen::VectorXd graspSeed(const EdgeQuery &edge) const;

        /// The stretch of an edge point: (edge index, kStretch cell along the edge).
        std::pair<int, long> stretch(const EdgeQuery &edge) const;

        /// How many stretches edge `edge` has (cells 0 .. n-1).
        long stretchCount(int edge) const;
        /// H_g the probe of a stretch tries (the hand as given): where a grasp of an object pushed just
        /// far enough over the edge there would be (params.graspStandoff, u*/2 beyond it).
        Eigen::Isometry3d stretchGrasp(const std::pair<int, long> &stretch) const;
        /// The stretch's liftable grasp configuration, probed on first use; empty if none is reachable.
        Eigen::VectorXd answer(const std::pair<int, long> &stretch) const;

        /// Whether this map answers for `task` under `params`: the same robot model, table, grasp frame,
        /// thickness, and the parameters the probes use.
        bool fits(const SlidingTask &task, const PlannerParams &params) const;

        /// Stretches probed so far (for statistics).
        std::size_t probed() const;

        /// One probed stretch: its edge, its kStretch cell along the edge, and its grasp configuration
        /// (empty: no reachable grasp).
        struct Entry
        {
            int edge;
            long cell;
            Eigen::VectorXd grasp;
        };

        /// Every stretch probed so far, in (edge, cell) order: what a persisted map stores.
        std::vector<Entry> entries() const;

        /// Take the answers of an earlier map of the same inputs (a persisted one), so that their
        /// stretches are not probed again; stretches already known keep their answer. Answers depend only
        /// on the inputs, so a plan is the same with a remembered map or a fresh one.
        /// \throws std::invalid_argument if an entry names no edge of the table, a negative cell, or a
        ///         grasp that is not empty, not finite or not of the robot's joint count (nothing is taken).
        void remember(const std::vector<Entry> &entries);

    private:
        static constexpr long kAnchor = 5;  ///< stretches: every kAnchor-th of an edge is probed on its own

        /// The stretch's grasp configuration (empty: unreachable), probed on first use.
        Eigen::VectorXd lookUp(const EdgeQuery &edge) const;
        Eigen::VectorXd probe(const std::pair<int, long> &stretch) const;

        static double micrometres(double metres) { return std::round(metres * 1e6) / 1e6; }

        SlidingTask geometry_;  ///< robot, table and grasp frame; no object
        double thickness_;      ///< the object's, to the micrometre
        PlannerParams params_;
        mutable std::mutex mutex_;
        mutable std::map<std::pair<int, long>, Eigen::VectorXd> known_;  ///< empty: no reachable grasp
    };

}  // namespace slideplan
