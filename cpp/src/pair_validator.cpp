#include "slideplan/pair_validator.hpp"

#include "slideplan/contact_frame.hpp"
#include "slideplan/hold_model.hpp"
#include "slideplan/validity.hpp"

#include <ompl/base/SpaceInformation.h>
#include <ompl/base/terminationconditions/IterationTerminationCondition.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/datastructures/NearestNeighborsLinear.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace slideplan
{
    namespace
    {
        /// OMPL's uniform sampler with a local seed, so the transfer motion is reproducible.
        class SeededSampler : public ob::RealVectorStateSampler
        {
        public:
            SeededSampler(const ob::StateSpace *space, std::uint_fast32_t seed) : ob::RealVectorStateSampler(space)
            {
                rng_.setLocalSeed(seed);
            }
        };

        /// The same grasp with the hand rolled by pi about its approach axis (z).
        Eigen::Isometry3d rolled(const Eigen::Isometry3d &grasp)
        {
            Eigen::Isometry3d result = grasp;
            result.linear() = grasp.linear() * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
            return result;
        }

        /// grasp_hold: the offset along the edge from H_g to the nearest strip `hold` wide across the approach
        /// in which the object extends `hold` along it, given the points within the hand's reach as
        /// (along the edge from H_g, along the outward normal); none if no strip holds that much.
        std::optional<double> holdingOffset(const std::vector<Eigen::Vector2d> &reached, double hold)
        {
            const auto holdsAt = [&](double along) {
                double low = std::numeric_limits<double>::infinity(), high = -low;
                for (const Eigen::Vector2d &point : reached)
                    if (std::abs(point.x() - along) <= 0.5 * hold)
                    {
                        low = std::min(low, point.y());
                        high = std::max(high, point.y());
                    }
                return high - low >= hold;
            };
            if (holdsAt(0.0))
                return 0.0;  // the paper's H_g holds the object
            std::vector<double> candidates;
            for (const Eigen::Vector2d &point : reached)
                candidates.push_back(point.x());
            // Nearest first; of two equally near, the one on the edge's negative side (the verifier's order).
            std::sort(candidates.begin(), candidates.end(),
                      [](double a, double b) { return std::abs(a) < std::abs(b) || (std::abs(a) == std::abs(b) && a < b); });
            for (double along : candidates)
                if (holdsAt(along))
                    return along;
            return std::nullopt;
        }

        /// Clears the object from the transfer world however the check ends.
        struct ObjectGuard
        {
            CollisionWorld &world;
            ~ObjectGuard() { world.clearObject(); }
        };
    }  // namespace

    PairValidator::PairValidator(std::shared_ptr<const SlidingTask> task, const PlannerParams &params,
                                 std::shared_ptr<const GraspMap> graspMap, const CollisionWorld *world)
      : task_(std::move(task))
      , params_(params)
      , world_(world ? world->clone()
                     : std::make_unique<CollisionWorld>(task_->robot, *task_->table, task_->obstacles, task_->contactLinks))
      , graspMap_(graspMap ? std::move(graspMap) : std::make_shared<const GraspMap>(*task_, params_))
      , plate_(params_.graspModel ? plateRegion(task_->objectXY) : PlateRegion{})
    {
        if (!graspMap_->fits(*task_, params_))
            throw std::invalid_argument("grasp map made for another robot, table, grasp frame, object thickness or "
                                        "grasp parameters");
    }

    Overhang PairValidator::overhang(const PlanarMotion &motion, bool exact) const
    {
        const SupportSurface &table = *task_->table;
        const Polygon2 &points = exact ? task_->objectXY : task_->footprintXY;
        Overhang result;
        result.motion = motion;
        result.comMargin = table.signedDistance(motion.apply(task_->objectCom));
        result.comInside = result.comMargin > 0.0 && result.comMargin >= params_.comMargin;
        std::vector<Eigen::Vector2d> &outside = outside_;  // reused: asked for every promising root pair
        std::vector<Eigen::Vector2d> &supported = supported_;
        outside.clear();
        supported.clear();
        double weight = 0.0;
        const Eigen::Isometry2d move = motion.transform();
        for (int i = 0; i < points.rows(); ++i)
        {
            const Eigen::Vector2d moved = move * points.row(i).transpose();
            if (table.contains(moved))
            {
                if (params_.supportHull)  // only the support rule asks for the points the table bears
                    supported.push_back(moved);
                continue;
            }
            const double w = exact ? 1.0 : task_->footprintWeight(i);
            outside.push_back(moved);
            result.outsideCentroid += w * moved;
            weight += w;
        }
        result.outsideCount = static_cast<int>(weight);
        if (outside.empty())
            return result;
        if (params_.supportHull && result.comInside)
        {
            // The table bears the object where it lies on it: past the hull of that part, the centre of mass
            // tips the object over the edge once the finger lets go (an L whose centre of mass lies off its
            // own material, inside the table).
            result.supportMargin = convexSignedDistance(convexHull(supported), motion.apply(task_->objectCom));
            result.supported = result.supportMargin >= params_.supportMargin;
        }
        result.outsideCentroid /= weight;
        result.edge = table.closestEdge(result.outsideCentroid);
        const auto beyond = [&](const Eigen::Vector2d &point) {
            result.overhang = std::max(result.overhang, (point - result.edge.closest).dot(result.edge.outwardNormal));
        };
        for (const auto &point : outside)
            beyond(point);
        if (!exact)
            for (const Eigen::Vector2d &vertex : task_->hullXY)
                if (const Eigen::Vector2d moved = move * vertex; !table.contains(moved))
                    beyond(moved);
        // The hand's free length s (graspStandoff) must lie beyond the edge: H_g moves outward to d_g >= s,
        // and what lies within that length towards the table is not in the hand.
        const double centroidBeyond = (result.outsideCentroid - result.edge.closest).dot(result.edge.outwardNormal);
        const double graspBeyond = std::max(centroidBeyond, params_.graspStandoff);
        result.graspPoint = result.outsideCentroid + (graspBeyond - centroidBeyond) * result.edge.outwardNormal;
        result.held = params_.graspStandoff > 0.0 ? result.overhang - std::max(0.0, graspBeyond - params_.graspStandoff)
                                                  : result.overhang;
        if (params_.graspHold > 0.0)
        {
            // The fingers close on what lies beyond their reach towards the table, on either side of H_g.
            const Eigen::Vector2d along(-result.edge.outwardNormal.y(), result.edge.outwardNormal.x());
            const double reach = std::max(params_.graspStandoff, params_.graspHold);
            std::vector<Eigen::Vector2d> &reached = reached_;
            reached.clear();
            for (const auto &point : outside)
                if (const double beyond = (point - result.graspPoint).dot(result.edge.outwardNormal); beyond >= -reach)
                    reached.emplace_back((point - result.graspPoint).dot(along), beyond);
            const std::optional<double> offset = holdingOffset(reached, params_.graspHold);
            result.holds = offset.has_value();
            if (offset)
                result.graspPoint += *offset * along;
        }
        return result;
    }

    HoldEstimate PairValidator::hold(const Overhang &overhang) const
    {
        // Judged where the object lay (the grasp carried back by the motion): the plate is not copied and moved.
        const Eigen::Isometry2d back = overhang.motion.transform().inverse();
        const Eigen::Vector2d &outward = overhang.edge.outwardNormal;
        return estimateHold(plate_, task_->objectCom, task_->thickness(), back * overhang.graspPoint,
                            (overhang.graspPoint - overhang.edge.closest).dot(outward), back.linear() * outward, params_);
    }

    bool PairValidator::graspable(const Overhang &overhang) const
    {
        return overhang.outsideCount > 0 && overhang.held >= params_.uStar && overhang.holds;
    }

    Eigen::Isometry3d PairValidator::graspPose(const Overhang &overhang) const
    {
        return sideGraspPose(overhang.graspPoint, overhang.edge, task_->table->height() + 0.5 * task_->thickness());
    }

    bool PairValidator::graspUnreachable(const EdgeQuery &edge) const
    {
        return params_.graspMap && (unreachable_.count(graspMap_->stretch(edge)) > 0 || !graspMap_->reachable(edge));
    }

    bool PairValidator::knownUnreachable(const Overhang &overhang) const
    {
        return overhang.outsideCount > 0 && graspUnreachable(overhang.edge);
    }

    bool PairValidator::graspReachableNear(const Eigen::Vector2d &point) const
    {
        return !graspUnreachable(task_->table->closestEdge(point));
    }

    std::string PairValidator::handCollision(const Eigen::Isometry3d &grasp) const
    {
        return world_->rigidCollision(task_->graspLink, grasp * task_->graspOffset.inverse());
    }

    std::string PairValidator::inCollision(const std::string &what, const Eigen::VectorXd &q) const
    {
        const auto pairs = world_->collisions(q, ContactMode::Free);
        return pairs.empty() ? what + " in collision" : what + " in collision (" + pairs[0].first + "-" + pairs[0].second + ")";
    }

    bool PairValidator::graspClear(const Overhang &overhang) const
    {
        const Eigen::Isometry3d grasp = graspPose(overhang);
        return handClear(grasp) || (params_.graspFlip && handClear(rolled(grasp)));
    }

    std::string PairValidator::reachGrasp(Eigen::Isometry3d &grasp, const EdgeQuery &edge, const Eigen::VectorXd &seed,
                                          std::mt19937_64 &rng, Eigen::VectorXd &solution) const
    {
        std::vector<Eigen::Isometry3d> orientations{grasp};
        if (params_.graspFlip)
            orientations.push_back(rolled(grasp));
        std::size_t tried = 0;
        std::string hit;  // what the hand met at the first orientation that met something
        for (const Eigen::Isometry3d &orientation : orientations)
        {
            // The hand against the table, checked before the IK that would only find it afterwards.
            if (std::string meets = handCollision(orientation); !meets.empty())
            {
                hit = hit.empty() ? meets : hit;
                continue;
            }
            ++tried;
            if (graspIk(orientation, edge, seed, rng, solution))
            {
                // Where the hand is: H_g itself, or turned within the tolerated rotation. The pre-grasp
                // backs off along this approach, and the plan records this pose.
                grasp = task_->robot->framePose(solution, task_->graspLink, task_->graspOffset);
                return {};
            }
        }
        if (tried == 0)
            return "grasp configuration in collision (" + hit + ")";
        // Only what IK ruled out holds for the whole stretch: the hand's collision depends on how far
        // beyond the edge the grasp is.
        if (tried == orientations.size() && params_.graspMap)
            unreachable_.insert(graspMap_->stretch(edge));
        return "grasp pose unreachable";
    }

    bool PairValidator::graspIk(const Eigen::Isometry3d &grasp, const EdgeQuery &edge, const Eigen::VectorXd &goal,
                                std::mt19937_64 &rng, Eigen::VectorXd &solution) const
    {
        if (liftableGraspIk(*task_, params_, grasp, goal, 1, rng, solution))
            return true;
        // The map's probe grasped within a centimetre of here: one attempt from it mostly converges where
        // the restarts below succeed about one time in five (warm triangle-table plans: 19 -> 10
        // iterations, as fewer pairs fail at the grasp).
        if (params_.graspMap)
            if (const Eigen::VectorXd seed = graspMap_->graspSeed(edge);
                seed.size() > 0 && liftableGraspIk(*task_, params_, grasp, seed, 1, rng, solution))
                return true;
        for (auto seed = graspSeeds_.rbegin(); seed != graspSeeds_.rend(); ++seed)
            if (liftableGraspIk(*task_, params_, grasp, *seed, 1, rng, solution))
                return true;
        // Side grasps at table height are a thin part of the workspace: one restart in ~5 succeeds. Ten
        // restarts miss about 1 reachable grasp in 10; 25 cost the triangle table 50% more planning time
        // (median 0.58 s against 0.38 s), 5 lose too many pairs.
        if (!liftableGraspIk(*task_, params_, grasp, Eigen::VectorXd(), 10, rng, solution))
            return false;
        constexpr std::size_t kRemembered = 8;
        if (graspSeeds_.size() == kRemembered)
            graspSeeds_.erase(graspSeeds_.begin());
        graspSeeds_.push_back(solution);
        return true;
    }

    bool PairValidator::straightMotion(const Eigen::VectorXd &from, const Eigen::VectorXd &to,
                                       std::vector<Eigen::VectorXd> &path) const
    {
        const RobotModel &robot = *task_->robot;
        // The dense path's bounds (docs/design.md 5) hold for the approach too: a joint step bounds the joints,
        // and where the fingertip, far out on the arm, moves further than max_tip_step the steps are halved.
        int steps = std::max(1, static_cast<int>(std::ceil((to - from).cwiseAbs().maxCoeff() / params_.maxJointStep)));
        std::vector<Eigen::VectorXd> segment;  // appended only if the whole motion is free
        for (int halving = 0; halving < 8; ++halving, steps *= 2)
        {
            segment.clear();
            Eigen::Vector3d previous = robot.fk(from).translation();
            bool dense = true;
            for (int k = 1; k <= steps && dense; ++k)
            {
                segment.push_back(k == steps ? to : Eigen::VectorXd(from + (to - from) * (static_cast<double>(k) / steps)));
                const Eigen::Vector3d tip = robot.fk(segment.back()).translation();
                dense = (tip - previous).norm() <= params_.maxTipStep;
                previous = tip;
            }
            if (dense)
                break;
        }
        if (segment.size() != static_cast<std::size_t>(steps))
            return false;  // the fingertip jumps: no such motion at this density
        for (const Eigen::VectorXd &q : segment)
            if (!world_->isValid(q, ContactMode::Free))
                return false;
        path.insert(path.end(), segment.begin(), segment.end());
        return true;
    }

    bool PairValidator::lift(const Eigen::VectorXd &goal, std::vector<Eigen::VectorXd> &path) const
    {
        const RobotModel &robot = *task_->robot;
        const Eigen::Isometry3d start = robot.fk(goal);
        // The fingertip rises from its contact depth below z_s to grasp_lift above z_s.
        const double rise = task_->surfaceZ + params_.graspLift - start.translation().z();
        // Steps of at most 0.8 maxTipStep, counted in sixteenths: a step that turns a joint further than
        // maxJointStep is halved, as near the robot's base a few millimetres of lift take more than that
        // (on the triangle table most goal roots that failed to lift). One still too long at a sixteenth
        // jumps to another IK branch: no lift.
        constexpr long kFine = 16;
        const long steps = static_cast<long>(std::ceil(rise / (0.8 * params_.maxTipStep)));
        IkOptions options = contactIkOptions(robot);
        options.maxAttempts = 1;  // from the previous waypoint only: a restart would jump
        std::mt19937_64 unused(0);
        Eigen::VectorXd previous = goal;
        long risen = 0, step = kFine;  // in sixteenths of a step
        while (risen < steps * kFine)
        {
            const long height = std::min(risen + step, steps * kFine);
            Eigen::Isometry3d target = start;
            target.translation().z() += rise * static_cast<double>(height) / static_cast<double>(steps * kFine);
            Eigen::VectorXd q;
            if (!robot.ik(target, previous, unused, q, options))
                return false;
            if ((q - previous).cwiseAbs().maxCoeff() > params_.maxJointStep)
            {
                if (step == 1)
                    return false;
                step /= 2;
                continue;
            }
            // The finger may still touch the object until it has risen to the lift height (verify.py
            // switches to the free-mode check at the same height).
            const bool clear = height == steps * kFine;
            if (!world_->isValid(q, clear ? ContactMode::Free : ContactMode::Sliding))
                return false;
            path.push_back(q);
            previous = q;
            risen = height;
        }
        return true;
    }

    bool PairValidator::canLift(const Eigen::VectorXd &goal) const
    {
        std::vector<Eigen::VectorXd> path;
        return lift(goal, path);
    }

    bool PairValidator::transferMotion(const Eigen::VectorXd &from, const Eigen::VectorXd &to, std::uint64_t seed,
                                       const ob::PlannerTerminationCondition &ptc,
                                       std::vector<Eigen::VectorXd> &path) const
    {
        if (straightMotion(from, to, path))
            return true;
        if (params_.transferIterations <= 0)
            return false;
        const RobotModel &robot = *task_->robot;
        const unsigned dof = robot.dof();
        auto space = jointSpace(robot);
        space->setStateSamplerAllocator([seed](const ob::StateSpace *s) {
            return std::make_shared<SeededSampler>(s, static_cast<std::uint_fast32_t>(seed));
        });
        auto si = std::make_shared<ob::SpaceInformation>(space);
        si->setStateValidityChecker([this, dof](const ob::State *state) {
            const auto *values = state->as<ob::RealVectorStateSpace::StateType>()->values;
            return world_->isValid(Eigen::Map<const Eigen::VectorXd>(values, dof), ContactMode::Free);
        });
        si->setStateValidityCheckingResolution(params_.maxJointStep / space->getMaximumExtent());
        si->setup();
        ob::ScopedState<ob::RealVectorStateSpace> start(space), goal(space);
        for (unsigned i = 0; i < dof; ++i)
        {
            start[i] = from(i);
            goal[i] = to(i);
        }
        auto pdef = std::make_shared<ob::ProblemDefinition>(si);
        pdef->setStartAndGoalStates(start, goal);
        og::RRTConnect planner(si);
        planner.setNearestNeighbors<ompl::NearestNeighborsLinear>();  // deterministic, and trees stay small
        planner.setProblemDefinition(pdef);
        // A count, not a time: the same pair gets the same verdict on any machine under any load.
        ob::IterationTerminationCondition iterations(static_cast<unsigned>(params_.transferIterations));
        const ob::PlannerStatus status = planner.solve(ob::plannerOrTerminationCondition(ptc, iterations));
        if (status != ob::PlannerStatus::EXACT_SOLUTION)
            return false;
        const auto &states = pdef->getSolutionPath()->as<og::PathGeometric>()->getStates();
        std::vector<Eigen::VectorXd> dense;
        Eigen::VectorXd previous = from;
        for (std::size_t i = 1; i < states.size(); ++i)
        {
            const auto *values = states[i]->as<ob::RealVectorStateSpace::StateType>()->values;
            const Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(values, dof);
            if (!straightMotion(previous, q, dense))
                return false;
            previous = q;
        }
        path.insert(path.end(), dense.begin(), dense.end());
        return true;
    }

    PairVerdict PairValidator::check(const Eigen::VectorXd &start, const Eigen::VectorXd &goal, std::mt19937_64 &rng,
                                     const ob::PlannerTerminationCondition &ptc) const
    {
        const RobotModel &robot = *task_->robot;
        PairVerdict verdict;
        verdict.overhang = overhang(objectMotion(robot.fk(start), robot.fk(goal)));
        const Overhang &result = verdict.overhang;
        if (!graspable(result))
        {
            verdict.reason = result.holds ? "overhang below u*" : "no place along the edge holds grasp_hold of the object";
            return verdict;
        }
        if (!result.comInside)
        {
            verdict.reason = "centre of mass off the table or within com_margin of its edge";
            return verdict;
        }
        if (!result.supported)
        {
            verdict.reason = "centre of mass within support_margin of the edge of what the table bears (support_hull)";
            return verdict;
        }
        if (std::abs(result.motion.yaw) > params_.maxObjectYaw)
        {
            verdict.reason = "object turns more than max_object_yaw";
            return verdict;
        }
        if (!task_->objectClear(result.motion))
        {
            verdict.reason = "object overlaps an obstacle at its final pose";
            return verdict;
        }

        // The checks above ran on the fixed-resolution footprint, a screen; from here on P_o itself (the
        // paper's definition): P_out, u and H_g at the centroid of P_out, once per pair that gets this far.
        verdict.overhang = overhang(result.motion, true);
        if (!result.supported)
        {
            verdict.reason = "centre of mass within support_margin of the edge of what the table bears on the full cloud";
            return verdict;
        }
        if (!graspable(result))
        {
            verdict.reason = result.holds ? "overhang below u* on the full cloud"
                                          : "no place along the edge holds grasp_hold of the object on the full cloud";
            return verdict;
        }
        if (params_.graspModel && !hold(result).holds)
        {
            verdict.reason = "the closed hand would not hold the object up (grasp_model)";
            return verdict;
        }
        if (knownUnreachable(result))
        {
            verdict.reason = "grasp pose unreachable";
            return verdict;
        }
        verdict.graspPose = graspPose(result);
        verdict.reason = reachGrasp(verdict.graspPose, result.edge, goal, rng, verdict.graspConfig);
        if (!verdict.reason.empty())
            return verdict;
        std::vector<Eigen::Vector2d> moved;  // the hull moves rigidly with the object (Eq. 2)
        for (const Eigen::Vector2d &vertex : task_->hullXY)
            moved.push_back(result.motion.apply(vertex));
        world_->setObject(moved, task_->surfaceZ);
        const ObjectGuard guard{*world_};
        if (!world_->isValid(verdict.graspConfig, ContactMode::Free))
        {
            verdict.reason = inCollision("grasp configuration", verdict.graspConfig);
            return verdict;
        }
        IkOptions nearOptions = graspIkOptions(params_);
        nearOptions.maxAttempts = 1;
        Eigen::Isometry3d preGraspPose = verdict.graspPose;
        preGraspPose.translation() -= params_.graspBackoff * verdict.graspPose.linear().col(2);
        Eigen::VectorXd preGrasp;
        if (!robot.ikForLink(task_->graspLink, preGraspPose, verdict.graspConfig, rng, preGrasp, nearOptions,
                            task_->graspOffset))
        {
            verdict.reason = "pre-grasp configuration unreachable";
            return verdict;
        }
        if (!world_->isValid(preGrasp, ContactMode::Free))
        {
            verdict.reason = inCollision("pre-grasp configuration", preGrasp);
            return verdict;
        }

        std::vector<Eigen::VectorXd> approach;
        if (!lift(goal, approach))
        {
            verdict.reason = "cannot lift the finger off the object";
            return verdict;
        }
        const std::uint64_t transferSeed = rng();
        if (!transferMotion(approach.back(), preGrasp, transferSeed, ptc, approach) ||
            !straightMotion(preGrasp, verdict.graspConfig, approach))
        {
            verdict.reason = "no transfer motion to the grasp";
            return verdict;
        }
        verdict.approach.reserve(approach.size() + 1);
        verdict.approach.push_back(goal);
        verdict.approach.insert(verdict.approach.end(), approach.begin(), approach.end());
        verdict.valid = true;
        return verdict;
    }

}  // namespace slideplan
