/// \file planner.hpp
/// Algorithm 1 of the paper: CBiRRT with sampleable regions. Start and goal forests grow from roots
/// drawn from C_s (Eq. 3) and C_g (Eq. 4) while CanAddRoot (Eq. 5) allows; every connection of a
/// start tree with a goal tree is checked by IsPairValid (IV-C.1). The baselines of section V-6 are
/// root policies of the same planner.
#pragma once

#include "slideplan/grasp_map.hpp"
#include "slideplan/pair_validator.hpp"
#include "slideplan/params.hpp"
#include "slideplan/regions.hpp"
#include "slideplan/result.hpp"
#include "slideplan/task.hpp"

#include <map>
#include <optional>
#include <stdexcept>
#include <ompl/base/Planner.h>
#include <ompl/datastructures/NearestNeighbors.h>
#include <random>

namespace slideplan
{
    /// Eq. 5: add a root while exp(-(N_s + N_g) / N*) > U(0, 1).
    bool canAddRoot(int startRoots, int goalRoots, double nStar, std::mt19937_64 &rng);

    class SlidingPlanner : public ompl::base::Planner
    {
    public:
        /// `graspMap`: shared with other plans of the same geometry (GraspMap::fits), or null for one of
        /// its own; either gives the same plan.
        SlidingPlanner(const ompl::base::SpaceInformationPtr &si, std::shared_ptr<const SlidingTask> task,
                       const PlannerParams &params, std::uint64_t seed, std::shared_ptr<const GraspMap> graspMap = nullptr);
        ~SlidingPlanner() override;

        /// Algorithm 1 until a valid pair connects or `ptc`. Start states of the problem definition are
        /// where the arm is (planning from a state): they are the start forest's roots and no other is
        /// drawn; when the first of them already leaves the object graspable (IsPairValid of it with
        /// itself: the end of a slide, seen again), the plan is that state and its grasp, without search.
        /// The states of a GoalStates goal join the goal forest before any drawn root. Both are
        /// taken when the forests are empty; INVALID_START / INVALID_GOAL if one is not a valid sliding
        /// state (a start state also with its fingertip on the object), givenRootProblem() says why. A
        /// second call grows the same forests further and reports only itself in result().
        ompl::base::PlannerStatus solve(const ompl::base::PlannerTerminationCondition &ptc) override;
        void clear() override;
        /// Both forests: every node a vertex (roots tagged 1 for start, 2 for goal), every tree edge an edge.
        void getPlannerData(ompl::base::PlannerData &data) const override;

        /// The plan of the last solve(): trajectory, object motion, grasp and statistics.
        const PlanResult &result() const { return result_; }
        /// Why the last given start or goal state was refused, in words (SlidingValidity::problem).
        const std::string &givenRootProblem() const { return givenRootProblem_; }

    private:
        struct Node
        {
            JointVector q;          ///< in the node itself: a tree node is one allocation
            Eigen::Isometry3d tip;  ///< Gamma(q), kept to bound the fingertip step without another FK
            Node *parent{nullptr};
            int root{-1};           ///< index of the tree's root in its forest
        };
        struct Forest;

        /// Pi.AddFromRegion(): one draw from the forest's region; a valid configuration becomes a root.
        bool addRoot(Forest &forest, const ompl::base::PlannerTerminationCondition &ptc);
        /// One step of ConstrainedExtend from `from` towards `target`: interpolate, project onto the
        /// relaxed constraint, and refuse the step if projection fails, it jumps (joint or fingertip
        /// bound), progress stalls or the state is invalid.
        /// In a start tree (`startTip`: its root's contact frame) the object must also stay clear of obstacles.
        bool constrainedStep(const JointsRef &from, const Eigen::Isometry3d &fromTip, const JointsRef &target,
                             const Eigen::Isometry3d *startTip, JointVector &q, Eigen::Isometry3d &tip) const;
        /// constrainedStep without the validity check.
        bool projectedStep(const JointsRef &from, const Eigen::Isometry3d &fromTip, const JointsRef &target, JointVector &q,
                           Eigen::Isometry3d &tip) const;
        /// The validity part of constrainedStep.
        bool stepValid(const JointsRef &q, const Eigen::Isometry3d &tip, const Eigen::Isometry3d *startTip) const;
        /// T.ConstrainedExtend(target, near): constrained steps until the target is reached or a step is refused.
        Node *constrainedExtend(Forest &forest, Node *near, const JointsRef &target, bool &reached);
        /// Beyond the paper: replace stretches of the path by shorter constrained walks between two of
        /// its waypoints (params.shortcutAttempts tries, fewer if the time limit comes first).
        void shortcut(std::vector<Eigen::VectorXd> &path, std::vector<Eigen::Isometry3d> &tips,
                      const ompl::base::PlannerTerminationCondition &ptc);
        /// Baselines: draw roots until the policy's fixed roots exist (and, for CBiRRT, form a valid pair).
        bool precomputeRoots(const ompl::base::PlannerTerminationCondition &ptc);
        /// The problem definition's start and goal states as roots; false if one is not a valid contact
        /// configuration (`start` tells which forest).
        bool addGivenRoots(bool &startValid);
        /// Pi_b.NearestTree(q) for the connection step: with screenPairs, only among trees whose root
        /// forms a promising pair with `root` of the other forest.
        Node *nearestForConnection(const Forest &forest, const JointsRef &q, const Forest &other, int root);
        /// Clutter (beyond the paper): along a connected path the object, moved by Eq. 2 from the start
        /// root, overlaps no obstacle (goal-tree part; the start trees were checked while growing), and
        /// the arm meets the object only through the contact links.
        bool pathClear(Node *startNode, Node *goalNode);
        /// The arm against the object's convex hull at its pose by Eq. 2 at each waypoint (sliding mode).
        bool armClearOfObject(const std::vector<Eigen::VectorXd> &path, const std::vector<Eigen::Isometry3d> &tips,
                              const Eigen::Isometry3d &startTip);
        /// Cheap part of IsPairValid (overhang >= u*, CoM on the table, grasp not on a stretch known to
        /// be unreachable), the geometry cached per root pair.
        bool promisingPair(int startRoot, int goalRoot);
        /// GetRoots + IsPairValid for a connection, with the verdict cached per root pair.
        const PairVerdict *validatePair(Node *startNode, Node *goalNode, const ompl::base::PlannerTerminationCondition &ptc);
        /// ExtractPath: root of the start tree -> connection -> root of the goal tree.
        void extractPath(Node *startNode, Node *goalNode, const PairVerdict &verdict,
                         const ompl::base::PlannerTerminationCondition &ptc);

        std::shared_ptr<const SlidingTask> task_;
        PlannerParams params_;
        std::uint64_t seed_;
        std::mt19937_64 rng_;
        std::shared_ptr<const SlidingConstraint> constraint_;
        std::shared_ptr<const SlidingValidity> validity_;
        std::unique_ptr<PairValidator> pairValidator_;
        std::unique_ptr<CollisionWorld> objectWorld_;  ///< holds the sliding object where pathClear puts it
        std::unique_ptr<Forest> startForest_, goalForest_;
        std::map<std::pair<int, int>, PairVerdict> verdicts_;
        /// The cheap part of IsPairValid per root pair, and whether the hand at its H_g is clear of the table
        /// (-1: not asked yet).
        std::map<std::pair<int, int>, std::pair<Overhang, signed char>> promising_;
        const Node *pairedRoot_{nullptr};
        bool givenStart_{false};  ///< the start forest is the problem definition's start states
        std::string givenRootProblem_;  ///< a goal root just drawn for a start root: the next sample of the start forest
        PlanResult result_;
    };

    /// A start configuration handed to planSliding that is not a valid contact configuration.
    class InvalidStartConfig : public std::invalid_argument
    {
    public:
        using std::invalid_argument::invalid_argument;
    };

    /// Plan one sliding task: sets up the OMPL space, runs SlidingPlanner::solve(ptc) and returns the
    /// result; planning time counts everything from here, including the baselines' precomputation.
    /// `graspMap` as for SlidingPlanner. `startConfig` (beyond the paper: re-planning during a slide):
    /// the arm is there, in contact with the object at its pose in `task`; the plan starts from it (and
    /// is that one configuration and a grasp when the object already overhangs enough there).
    /// \throws std::invalid_argument for invalid parameters, an unreachable object, u* beyond the object
    ///         (on a convex table: beyond what it can overhang with its centre of mass com_margin inside)
    ///         or a grasp map that does not fit; InvalidStartConfig, saying why, for a start configuration
    ///         that is not a valid sliding state with its fingertip on the object.
    PlanResult planSliding(std::shared_ptr<const SlidingTask> task, const PlannerParams &params, std::uint64_t seed,
                           const ompl::base::PlannerTerminationCondition &ptc, std::shared_ptr<const GraspMap> graspMap = nullptr,
                           const std::optional<Eigen::VectorXd> &startConfig = std::nullopt);

}  // namespace slideplan
