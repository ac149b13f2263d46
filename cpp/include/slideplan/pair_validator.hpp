/// \file pair_validator.hpp
/// IsPairValid of Algorithm 1 (paper IV-C.1): does sliding from phi_s to phi_g leave the object in a
/// graspable pose, and can the hand reach the side grasp from phi_g?
#pragma once

#include "slideplan/collision.hpp"
#include "slideplan/grasp_map.hpp"
#include "slideplan/hold_model.hpp"
#include "slideplan/object_motion.hpp"
#include "slideplan/params.hpp"
#include "slideplan/task.hpp"

#include <ompl/base/PlannerTerminationCondition.h>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace slideplan
{
    /// The cheap geometric part of pair validation: P'_o, P_out, u, CoM.
    struct Overhang
    {
        PlanarMotion motion;
        int outsideCount{0};          ///< |P_out|
        Eigen::Vector2d outsideCentroid{Eigen::Vector2d::Zero()};  ///< geometric centre of P_out
        EdgeQuery edge;               ///< edge (e_i, e_j) of Q closest to that centroid
        double overhang{0.0};         ///< u: largest distance of P_out beyond that edge
        Eigen::Vector2d graspPoint{Eigen::Vector2d::Zero()};  ///< H_g's position: the centroid, moved out to grasp_standoff
                                                                ///< and along the edge onto the object (grasp_hold)
        bool holds{true};             ///< some place along the edge puts grasp_hold of the object between the fingers
        double held{0.0};             ///< overhang held by the hand: u, less what lies within the hand's free length
        bool comInside{false};        ///< CoM of P'_o inside Q, at least params.comMargin from its boundary
        double comMargin{0.0};        ///< signed distance of that CoM to the boundary of Q (m, > 0 inside)
        /// With params.supportHull (and the CoM inside): the CoM's signed distance inside the convex hull of
        /// P'_o's points on Q, what the table bears (m; +infinity when not asked), and whether it is at least
        /// params.supportMargin.
        double supportMargin{std::numeric_limits<double>::infinity()};
        bool supported{true};
    };

    struct PairVerdict
    {
        bool valid{false};
        std::string reason;           ///< why a pair was rejected: for statistics and debugging
        Overhang overhang;
        Eigen::Isometry3d graspPose{Eigen::Isometry3d::Identity()};
        Eigen::VectorXd graspConfig;
        std::vector<Eigen::VectorXd> approach;  ///< phi_g -> lift -> pre-grasp -> grasp, dense
    };

    class PairValidator
    {
    public:
        /// `graspMap`: a map shared with other plans of the same geometry (GraspMap::fits), or null for
        /// one of its own. `world`: a collision world of the task to clone, or null to build one.
        /// \throws std::invalid_argument for a map that does not fit.
        PairValidator(std::shared_ptr<const SlidingTask> task, const PlannerParams &params,
                      std::shared_ptr<const GraspMap> graspMap = nullptr, const CollisionWorld *world = nullptr);

        /// IsPairValid(phi_s, phi_g): cheap geometry first, then grasp IK, then the transfer motion.
        PairVerdict check(const Eigen::VectorXd &start, const Eigen::VectorXd &goal, std::mt19937_64 &rng,
                          const ompl::base::PlannerTerminationCondition &ptc) const;

        /// P'_o by Eq. 2, P_out by point-in-polygon, u from the edge closest to the centroid of P_out:
        /// on P_o itself (`exact`), or on its fixed-resolution footprint, u then also over the convex
        /// hull's vertices (the farthest point of P_o beyond an edge is one of them).
        Overhang overhang(const PlanarMotion &motion, bool exact = false) const;

        /// Beyond the paper (params.graspModel): whether the hand closed at the overhang's grasp point holds
        /// the object up (hold_model.hpp), on P_o itself.
        HoldEstimate hold(const Overhang &overhang) const;

        /// Whether the hand holds at least u* of the object (IV-C.1's u >= u*, with params.graspStandoff).
        bool graspable(const Overhang &overhang) const;

        /// H_g: the grasp frame at the centroid of P_out (moved out to grasp_standoff), mid-thickness, approaching perpendicular to
        /// the edge in the table plane, the straight (+Y) finger above the object.
        Eigen::Isometry3d graspPose(const Overhang &overhang) const;

        /// Beyond the paper (params.graspMap): whether the grasp map, or an earlier grasp IK of this plan,
        /// rules out a side grasp on the stretch of table edge this overhang's grasp falls on.
        bool knownUnreachable(const Overhang &overhang) const;

        /// Beyond the paper (params.graspMap): the same for the stretch of table edge nearest to `point`
        /// (a goal root's contact).
        bool graspReachableNear(const Eigen::Vector2d &point) const;

        /// Whether the hand at H_g for `overhang`, as given or (params.graspFlip) rolled by pi about its
        /// approach axis, is clear of the table and the obstacles. The hand is rigid past the grasp link's
        /// last joint, so this needs no IK: at zero grasp_standoff a fingertip under the table top rules out
        /// most grasps by a corner of Q.
        bool graspClear(const Overhang &overhang) const;

        /// Whether the finger can lift off from `goal` with no object in the way: a goal root that cannot
        /// fails the lift of every pair it would form (the object only adds an obstacle).
        bool canLift(const Eigen::VectorXd &goal) const;

    private:
        /// Grasp IK: from phi_g, then (params.graspMap) from the map's grasp on the stretch of `edge`,
        /// then from earlier successful grasps (nearby grasp poses have nearby solutions), then random
        /// restarts.
        bool graspIk(const Eigen::Isometry3d &grasp, const EdgeQuery &edge, const Eigen::VectorXd &goal,
                     std::mt19937_64 &rng, Eigen::VectorXd &solution) const;
        /// Grasp IK for `grasp` on `edge`, then (params.graspFlip) for it rolled by pi about its approach
        /// axis, which then replaces `grasp`; an orientation whose hand meets the table or an obstacle is
        /// not tried. Empty on success, else why not. A stretch whose every orientation failed its IK is
        /// remembered as unreachable.
        std::string reachGrasp(Eigen::Isometry3d &grasp, const EdgeQuery &edge, const Eigen::VectorXd &seed,
                               std::mt19937_64 &rng, Eigen::VectorXd &solution) const;
        bool handClear(const Eigen::Isometry3d &grasp) const { return handCollision(grasp).empty(); }
        /// What the hand's rigid parts meet at `grasp` ("link-obstacle"), empty if nothing.
        std::string handCollision(const Eigen::Isometry3d &grasp) const;
        /// `what` in collision at q, naming the first colliding pair: a rejection reason counted per pair.
        std::string inCollision(const std::string &what, const Eigen::VectorXd &q) const;
        bool graspUnreachable(const EdgeQuery &edge) const;
        bool lift(const Eigen::VectorXd &goal, std::vector<Eigen::VectorXd> &path) const;
        bool straightMotion(const Eigen::VectorXd &from, const Eigen::VectorXd &to, std::vector<Eigen::VectorXd> &path) const;
        bool transferMotion(const Eigen::VectorXd &from, const Eigen::VectorXd &to, std::uint64_t seed,
                            const ompl::base::PlannerTerminationCondition &ptc, std::vector<Eigen::VectorXd> &path) const;

        std::shared_ptr<const SlidingTask> task_;
        PlannerParams params_;
        std::unique_ptr<CollisionWorld> world_;  ///< holds the object at its final pose while a pair is checked
        mutable std::vector<Eigen::Vector2d> outside_;  ///< overhang()'s points beyond Q, kept to reuse the memory
        mutable std::vector<Eigen::Vector2d> supported_;  ///< and its points on Q
        mutable std::vector<Eigen::Vector2d> reached_;  ///< of those, the ones within the fingers' reach (grasp_hold)
        mutable std::vector<Eigen::VectorXd> graspSeeds_;  ///< recent successful grasp configurations
        std::shared_ptr<const GraspMap> graspMap_;
        mutable std::set<std::pair<int, long>> unreachable_;  ///< stretches where this plan's grasp IK failed
        PlateRegion plate_;  ///< the material P_o covers where it lies (grasp_model), empty without the model
    };

}  // namespace slideplan
