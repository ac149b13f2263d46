#include "slideplan/planner.hpp"

#include "slideplan/contact_frame.hpp"
#include "slideplan/paired_goal.hpp"

#include <chrono>
#include <cmath>
#include <ompl/base/PlannerData.h>
#include <ompl/base/ScopedState.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/goals/GoalStates.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/datastructures/NearestNeighborsLinear.h>
#include <ompl/geometric/PathGeometric.h>
#include <sstream>

namespace ob = ompl::base;

namespace slideplan
{
    bool canAddRoot(int startRoots, int goalRoots, double nStar, std::mt19937_64 &rng)
    {
        return std::exp(-(startRoots + goalRoots) / nStar) > std::uniform_real_distribution<double>(0.0, 1.0)(rng);
    }

    /// Pi: the trees grown from one region's roots, with one nearest-neighbour structure over all of them.
    struct SlidingPlanner::Forest
    {
        bool isStart;
        std::unique_ptr<ContactRegion> region;
        std::vector<std::unique_ptr<Node>> nodes;
        std::vector<Node *> roots;
        // Linear search: deterministic (GNAT draws its pivots from a global RNG) and fast enough for
        // the few thousand nodes a plan needs.
        ompl::NearestNeighborsLinear<Node *> nearest;

        Forest(bool start, std::unique_ptr<ContactRegion> sampler) : isStart(start), region(std::move(sampler))
        {
            nearest.setDistanceFunction([](const Node *a, const Node *b) { return (a->q - b->q).norm(); });
        }

        Node *add(const JointsRef &q, const Eigen::Isometry3d &tip, Node *parent)
        {
            nodes.push_back(std::make_unique<Node>(Node{q, tip, parent, parent ? parent->root : static_cast<int>(roots.size())}));
            Node *node = nodes.back().get();
            if (!parent)
                roots.push_back(node);
            nearest.add(node);
            return node;
        }

        Node *nearestTo(const JointsRef &q) const
        {
            Node query{q, Eigen::Isometry3d::Identity(), nullptr, -1};
            return nearest.nearest(&query);
        }
    };

    SlidingPlanner::SlidingPlanner(const ob::SpaceInformationPtr &si, std::shared_ptr<const SlidingTask> task,
                                   const PlannerParams &params, std::uint64_t seed, std::shared_ptr<const GraspMap> graspMap)
      : ob::Planner(si, "SlidingPlanner"), task_(std::move(task)), params_(params), seed_(seed), rng_(seed)
    {
        specs_.approximateSolutions = false;
        specs_.directed = true;
        // N* is read at every iteration, so OMPL's tools (benchmarking, parameter sweeps) may set it by
        // name; the other parameters shape the regions and the validator built below.
        ob::Planner::params().declareParam<double>("n_star", [this](double v) { params_.nStar = v; },
                                                   [this] { return params_.nStar; });
        auto constraint = std::make_shared<SlidingConstraint>(task_->robot, task_->surfaceZ, params_);
        auto validity = std::make_shared<SlidingValidity>(si_, task_, constraint);
        si_->setStateValidityChecker(validity);
        constraint_ = constraint;
        validity_ = validity;
        pairValidator_ = std::make_unique<PairValidator>(task_, params_, std::move(graspMap), &validity->world());
        objectWorld_ = validity->world().clone();
        objectWorld_->setObject(task_->hullXY, task_->surfaceZ);  // at its start pose; moved along paths
        clear();
    }

    SlidingPlanner::~SlidingPlanner() = default;

    void SlidingPlanner::clear()
    {
        ob::Planner::clear();
        startForest_ = std::make_unique<Forest>(true, std::make_unique<StartRegion>(validity_, params_));
        goalForest_ = std::make_unique<Forest>(false, std::make_unique<GoalRegion>(validity_, params_));
        verdicts_.clear();
        promising_.clear();
        pairedRoot_ = nullptr;
        givenStart_ = false;
        givenRootProblem_.clear();
        rng_.seed(seed_);
        result_ = PlanResult();
    }

    bool SlidingPlanner::addRoot(Forest &forest, const ob::PlannerTerminationCondition &ptc)
    {
        ++result_.stats.rootSamples;
        // Warm start from the forest's latest root (neighbouring contact poses have nearby IK solutions),
        // else from the other forest's: a 6-joint arm's IK branches are separate components of the
        // constraint manifold, and trees rooted in different branches never connect.
        const Forest &other = &forest == startForest_.get() ? *goalForest_ : *startForest_;
        Eigen::VectorXd seed;
        if (!forest.roots.empty())
            seed = forest.roots.back()->q;
        else if (!other.roots.empty())
            seed = other.roots.back()->q;
        Eigen::VectorXd q;
        // Beyond the paper: some goal roots are drawn for a start root (paired_goal.hpp), the others as
        // Algorithm 1 draws them. The baselines draw theirs as published.
        const bool paired = !forest.isStart && params_.policy == RootPolicy::Sampled && !startForest_->roots.empty() &&
                            std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < params_.pairedGoals;
        if (paired)
        {
            const Node *start = startForest_->roots[std::uniform_int_distribution<std::size_t>(0, startForest_->roots.size() - 1)(rng_)];
            Eigen::Isometry3d target;
            // IK from the start root's own configuration: in its IK branch, so that the two trees can meet.
            if (!pairedGoalTarget(*task_, params_, *pairValidator_, start->tip, rng_, target) ||
                !forest.region->reach(target, rng_, start->q, q, ptc))
                return false;
        }
        else if (!forest.region->sample(rng_, seed, q, ptc))
            return false;
        const Eigen::Isometry3d tip = task_->robot->fk(q);
        // Beyond the paper: a goal root by an edge stretch with no reachable side grasp mostly grows trees
        // whose pairs fail at the grasp (the triangle table's far edges). One in kKeep is kept: the
        // object may overhang a stretch further along, and the map's IK is not a proof. A paired root's
        // own grasp is screened by the grasp map already.
        constexpr int kKeep = 10;
        if (!forest.isStart && !paired && params_.goalGraspFilter && !pairValidator_->graspReachableNear(tip.translation().head<2>()) &&
            std::uniform_int_distribution<int>(1, kKeep)(rng_) != 1)
            return false;
        // With pair screening: a goal root the finger cannot lift off from fails every pair it would
        // form, after their grasp IK (on the triangle table 2.3 such pairs per plan).
        if (!forest.isStart && params_.screenPairs && !pairValidator_->canLift(q))
            return false;
        Node *root = forest.add(q, tip, nullptr);
        if (paired)
            pairedRoot_ = root;
        return true;
    }

    bool SlidingPlanner::constrainedStep(const JointsRef &from, const Eigen::Isometry3d &fromTip, const JointsRef &target,
                                         const Eigen::Isometry3d *startTip, JointVector &q, Eigen::Isometry3d &tip) const
    {
        return projectedStep(from, fromTip, target, q, tip) && stepValid(q, tip, startTip);
    }

    bool SlidingPlanner::stepValid(const JointsRef &q, const Eigen::Isometry3d &tip, const Eigen::Isometry3d *startTip) const
    {
        // Where the slide started is known in start trees only: there the object must stay clear of
        // the obstacles and on the table (goal trees are checked once connected, pathClear).
        if (!validity_->isValid(q, tip))
            return false;
        if (!startTip)
            return true;
        const PlanarMotion motion = objectMotion(*startTip, tip);
        return task_->objectClear(motion) && (!params_.comSupported || task_->comOnTable(motion));
    }

    bool SlidingPlanner::projectedStep(const JointsRef &from, const Eigen::Isometry3d &fromTip, const JointsRef &target,
                                       JointVector &q, Eigen::Isometry3d &tip) const
    {
        const JointVector towards = target - from;
        // Aim inside the step bounds: projection moves the state a little further.
        double scale = std::min(1.0, 0.9 * params_.maxJointStep / towards.cwiseAbs().maxCoeff());
        bool withinStep = false;
        for (int halving = 0; halving < 4 && !withinStep; ++halving, scale *= 0.5)
        {
            q = from + scale * towards;
            if (!constraint_->projectWithTip(q, tip))
                return false;
            withinStep = (q - from).cwiseAbs().maxCoeff() <= params_.maxJointStep &&
                         (tip.translation() - fromTip.translation()).norm() <= params_.maxTipStep;
        }
        if (!withinStep)
            return false;  // the manifold bends away too fast here: a jump, not a step
        if (params_.maxYawRate > 0.0 && std::abs(objectMotion(fromTip, tip).yaw) >
                                            params_.maxYawRate * (tip.translation() - fromTip.translation()).head<2>().norm())
            return false;  // turns the object too fast for the distance slid
        const double step = (q - from).norm(), before = towards.norm(), after = (target - q).norm();
        return step >= 1e-3 * params_.maxJointStep && after <= before - 0.25 * step;  // else stalled: the
                                                                                      // projection (or a joint limit) undoes the step
    }

    SlidingPlanner::Node *SlidingPlanner::constrainedExtend(Forest &forest, Node *near, const JointsRef &target, bool &reached)
    {
        reached = false;
        Node *current = near;
        JointVector q;
        Eigen::Isometry3d tip;
        for (;;)
        {
            if ((target - current->q).cwiseAbs().maxCoeff() < 1e-9)
            {
                reached = true;
                return current;
            }
            if (!constrainedStep(current->q, current->tip, target, forest.isStart ? &forest.roots[current->root]->tip : nullptr,
                                 q, tip))
                return current;
            current = forest.add(q, tip, current);
        }
    }

    void SlidingPlanner::shortcut(std::vector<Eigen::VectorXd> &path, std::vector<Eigen::Isometry3d> &tips,
                                  const ob::PlannerTerminationCondition &ptc)
    {
        // What execution pays for : fingertip travel over the table and the object's turning.
        const auto stepCost = [this](const Eigen::Isometry3d &from, const Eigen::Isometry3d &to) {
            return (to.translation() - from.translation()).head<2>().norm() +
                   params_.shortcutYawWeight * std::abs(objectMotion(from, to).yaw);
        };
        const auto cost = [&](const std::vector<Eigen::Isometry3d> &poses, std::size_t from, std::size_t to) {
            double total = 0.0;
            for (std::size_t k = from + 1; k <= to; ++k)
                total += stepCost(poses[k - 1], poses[k]);
            return total;
        };
        // A deadline that stops the shortcut also discards the plan (extractPath): its length must not depend on time.
        for (int attempt = 0; attempt < params_.shortcutAttempts && path.size() > 2 && !ptc; ++attempt)
        {
            std::uniform_int_distribution<std::size_t> pick(0, path.size() - 1);
            std::size_t i = pick(rng_), j = pick(rng_);
            if (i > j)
                std::swap(i, j);
            if (j < i + 2)
                continue;
            // Walk the constraint manifold from waypoint i to waypoint j; keep the walk if it arrives
            // at a lower cost. The endpoints stay, so the object motion of Eq. 2 is unchanged.
            const std::size_t maxSteps = 2 * (j - i) + 10;
            const double stretchCost = cost(tips, i, j);
            std::vector<Eigen::VectorXd> walk{path[i]};
            std::vector<Eigen::Isometry3d> walkTips{tips[i]};
            JointVector q;
            Eigen::Isometry3d tip;
            // The walk's cost up to its second-to-last point is final (the last may still be replaced by
            // waypoint j): once it reaches the stretch's cost the walk cannot be kept, so stop walking.
            // Validity is checked only for a walk that arrives cheaper: most walks do not.
            double settledCost = 0.0;
            while (walk.size() < maxSteps && settledCost < stretchCost &&
                   (path[j] - walk.back()).cwiseAbs().maxCoeff() >= 1e-9 &&
                   projectedStep(walk.back(), walkTips.back(), path[j], q, tip))
            {
                if (walk.size() >= 2)
                    settledCost += stepCost(walkTips[walkTips.size() - 2], walkTips.back());
                walk.push_back(q);
                walkTips.push_back(tip);
            }
            if ((path[j] - walk.back()).cwiseAbs().maxCoeff() >= 1e-9)
                continue;
            const Eigen::VectorXd landed = walk.back();
            const Eigen::Isometry3d landedTip = walkTips.back();
            walk.back() = path[j];  // arrived: the last step landed on waypoint j itself
            walkTips.back() = tips[j];
            if (cost(walkTips, 0, walkTips.size() - 1) >= stretchCost)
                continue;
            bool valid = stepValid(landed, landedTip, &tips.front());
            for (std::size_t k = 1; k + 1 < walk.size() && valid; ++k)
                valid = stepValid(walk[k], walkTips[k], &tips.front());
            if (!valid || !armClearOfObject(walk, walkTips, tips.front()))
                continue;
            path.erase(path.begin() + i, path.begin() + j + 1);
            path.insert(path.begin() + i, walk.begin(), walk.end());
            tips.erase(tips.begin() + i, tips.begin() + j + 1);
            tips.insert(tips.begin() + i, walkTips.begin(), walkTips.end());
        }
    }

    bool SlidingPlanner::armClearOfObject(const std::vector<Eigen::VectorXd> &path,
                                          const std::vector<Eigen::Isometry3d> &tips, const Eigen::Isometry3d &startTip)
    {
        for (std::size_t k = 0; k < path.size(); ++k)
        {
            objectWorld_->moveObject(objectMotion(startTip, tips[k]));
            if (!objectWorld_->objectFree(path[k], ContactMode::Sliding))  // the rest was checked as the path grew
                return false;
        }
        return true;
    }

    bool SlidingPlanner::pathClear(Node *startNode, Node *goalNode)
    {
        std::vector<Eigen::VectorXd> path;
        std::vector<Eigen::Isometry3d> tips;
        for (Node *node = startNode; node; node = node->parent)
        {
            path.push_back(node->q);
            tips.push_back(node->tip);
        }
        const Eigen::Isometry3d startTip = tips.back();
        for (Node *node = goalNode->parent; node; node = node->parent)
        {
            const PlanarMotion motion = objectMotion(startTip, node->tip);
            if (!task_->objectClear(motion))
            {
                ++result_.stats.rejections["object meets an obstacle along the path"];
                return false;
            }
            if (params_.comSupported && !task_->comOnTable(motion))
            {
                ++result_.stats.rejections["centre of mass off the table along the path"];
                return false;
            }
            path.push_back(node->q);
            tips.push_back(node->tip);
        }
        if (!armClearOfObject(path, tips, startTip))
        {
            ++result_.stats.rejections["arm meets the sliding object along the path"];
            return false;
        }
        return true;
    }

    const PairVerdict *SlidingPlanner::validatePair(Node *startNode, Node *goalNode, const ob::PlannerTerminationCondition &ptc)
    {
        const std::pair<int, int> key(startNode->root, goalNode->root);
        auto it = verdicts_.find(key);
        // CBiRRT's one pair was validated before its trees grew: its verdict stands either way.
        const bool recheck = !params_.cacheVerdicts && params_.policy != RootPolicy::Fixed;
        if (it == verdicts_.end() || recheck)
        {
            ++result_.stats.pairsChecked;
            PairVerdict verdict = pairValidator_->check(startForest_->roots[key.first]->q, goalForest_->roots[key.second]->q, rng_, ptc);
            if (!verdict.valid)
            {
                ++result_.stats.pairsRejected;
                ++result_.stats.rejections[verdict.reason];
            }
            it = verdicts_.insert_or_assign(key, std::move(verdict)).first;
        }
        return &it->second;
    }

    bool SlidingPlanner::promisingPair(int startRoot, int goalRoot)
    {
        const std::pair<int, int> key(startRoot, goalRoot);
        const auto verdict = verdicts_.find(key);
        if (verdict != verdicts_.end())
            return verdict->second.valid;
        auto it = promising_.find(key);
        if (it == promising_.end())
            it = promising_
                     .emplace(key, std::make_pair(pairValidator_->overhang(objectMotion(startForest_->roots[startRoot]->tip,
                                                                                        goalForest_->roots[goalRoot]->tip)),
                                                  static_cast<signed char>(-1)))
                     .first;
        // The grasp map grows while planning, so it is consulted every time.
        auto &[overhang, clear] = it->second;
        if (!pairValidator_->graspable(overhang) || !overhang.comInside || std::abs(overhang.motion.yaw) > params_.maxObjectYaw ||
            pairValidator_->knownUnreachable(overhang))
            return false;
        if (clear < 0)
            clear = pairValidator_->graspClear(overhang);
        return clear;
    }

    SlidingPlanner::Node *SlidingPlanner::nearestForConnection(const Forest &forest, const JointsRef &q,
                                                               const Forest &other, int root)
    {
        if (!params_.screenPairs)
            return forest.nearestTo(q);
        Node *best = nullptr;
        double bestDistance = std::numeric_limits<double>::infinity();
        // Per tree, decided on first use; signed, since plain char is unsigned on some targets (aarch64).
        std::vector<signed char> promising(forest.roots.size(), -1);
        for (const auto &node : forest.nodes)
        {
            signed char &ok = promising[node->root];
            if (ok < 0)
                ok = other.isStart ? promisingPair(root, node->root) : promisingPair(node->root, root);
            if (!ok)
                continue;
            const double distance = (node->q - q).norm();
            if (distance < bestDistance)
            {
                bestDistance = distance;
                best = node.get();
            }
        }
        return best ? best : forest.nearestTo(q);  // nothing promising yet: keep exploring as Algorithm 1 does
    }

    bool SlidingPlanner::precomputeRoots(const ob::PlannerTerminationCondition &ptc)
    {
        if (params_.policy == RootPolicy::Fixed)
        {
            // CBiRRT: draw start/goal pairs until one passes IsPairValid; only then plan the motion.
            Eigen::VectorXd start, goal;
            while (!ptc)
            {
                result_.stats.rootSamples += 2;
                if (!startForest_->region->sample(rng_, start, start, ptc) || !goalForest_->region->sample(rng_, goal, goal, ptc))
                    continue;
                ++result_.stats.pairsChecked;
                PairVerdict verdict = pairValidator_->check(start, goal, rng_, ptc);
                if (!verdict.valid)
                {
                    ++result_.stats.pairsRejected;
                    ++result_.stats.rejections[verdict.reason];
                    continue;
                }
                startForest_->add(start, task_->robot->fk(start), nullptr);
                goalForest_->add(goal, task_->robot->fk(goal), nullptr);
                verdicts_.emplace(std::make_pair(0, 0), std::move(verdict));
                return true;
            }
            return false;
        }
        // Algorithm 1 line 1 (Init) for both forests; CBiRRT2's single start is drawn the same way.
        while (!ptc && startForest_->roots.empty())
            addRoot(*startForest_, ptc);
        while (!ptc && goalForest_->roots.empty())
            addRoot(*goalForest_, ptc);
        return !startForest_->roots.empty() && !goalForest_->roots.empty();
    }

    void SlidingPlanner::extractPath(Node *startNode, Node *goalNode, const PairVerdict &verdict,
                                     const ob::PlannerTerminationCondition &ptc)
    {
        std::vector<Node *> nodes;
        for (Node *node = startNode; node; node = node->parent)
            nodes.push_back(node);
        std::reverse(nodes.begin(), nodes.end());
        for (Node *node = goalNode->parent; node; node = node->parent)  // goalNode duplicates startNode
            nodes.push_back(node);
        for (Node *node : nodes)
        {
            result_.trajectory.push_back(node->q);
            result_.fingertipPoses.push_back(node->tip);
        }
        shortcut(result_.trajectory, result_.fingertipPoses, ptc);
        // ptc only ever turns true: if it is false now, no step of this plan (an IK, a transfer, the
        // shortcut) was cut by it, so the plan is the one any machine makes. Otherwise it is not returned.
        if (ptc)
        {
            result_.trajectory.clear();
            result_.fingertipPoses.clear();
            return;
        }
        for (std::size_t k = 1; k < result_.fingertipPoses.size(); ++k)
        {
            const PlanarMotion step = objectMotion(result_.fingertipPoses[k - 1], result_.fingertipPoses[k]);
            result_.stats.fingertipPath += (result_.fingertipPoses[k].translation() - result_.fingertipPoses[k - 1].translation())
                                               .head<2>()
                                               .norm();
            result_.stats.yawTravel += std::abs(step.yaw);
        }
        auto path = std::make_shared<ompl::geometric::PathGeometric>(si_);
        for (const Eigen::VectorXd &q : result_.trajectory)
        {
            ob::State *state = si_->allocState();
            std::copy(q.data(), q.data() + q.size(), state->as<ob::RealVectorStateSpace::StateType>()->values);
            path->append(state);
            si_->freeState(state);
        }
        if (pdef_)
            pdef_->addSolutionPath(path, false, 0.0, getName());
        result_.startConfig = nodes.front()->q;
        result_.goalConfig = nodes.back()->q;
        result_.objectMotion = verdict.overhang.motion;
        result_.overhang = verdict.overhang.overhang;
        result_.stats.comMargin = verdict.overhang.comMargin;
        result_.graspPose = verdict.graspPose;
        result_.graspConfig = verdict.graspConfig;
        result_.approach = verdict.approach;
        result_.status = "solved";
    }

    bool SlidingPlanner::addGivenRoots(bool &startValid)
    {
        const RobotModel &robot = *task_->robot;
        const auto addValid = [&](Forest &forest, const ob::State *state) {
            const auto *values = state->as<ob::RealVectorStateSpace::StateType>()->values;
            const Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(values, robot.dof());
            const Eigen::Isometry3d tip = robot.fk(q);
            givenRootProblem_ = validity_->problem(q, tip);
            // A start root pushes the object: its fingertip must be on it (the hull of P_o; Eq. 3 draws from P_o).
            if (givenRootProblem_.empty() && forest.isStart && !pointInConvex(task_->hullXY, tip.translation().head<2>()))
            {
                std::ostringstream message;
                message << "puts the fingertip at (" << tip.translation().x() << ", " << tip.translation().y()
                        << "), not on the object";
                givenRootProblem_ = message.str();
            }
            if (!givenRootProblem_.empty())
                return false;
            forest.add(q, tip, nullptr);
            return true;
        };
        startValid = true;
        // Not pis_.nextStart(): it skips an invalid start with a warning, and the caller must hear of it.
        for (unsigned i = 0; pdef_ && i < pdef_->getStartStateCount(); ++i)
            if (!addValid(*startForest_, pdef_->getStartState(i)))
                return startValid = false;
        givenStart_ = !startForest_->roots.empty();
        if (const auto *goals = pdef_ ? dynamic_cast<const ob::GoalStates *>(pdef_->getGoal().get()) : nullptr)
            for (std::size_t i = 0; i < goals->getStateCount(); ++i)
                if (!addValid(*goalForest_, goals->getState(i)))
                    return false;
        return true;
    }

    void SlidingPlanner::getPlannerData(ob::PlannerData &data) const
    {
        ob::Planner::getPlannerData(data);
        // Nodes hold Eigen vectors, not OMPL states: the states made here live until the data owns copies.
        std::vector<ob::State *> states;
        for (const Forest *forest : {startForest_.get(), goalForest_.get()})
        {
            std::map<const Node *, unsigned> index;
            for (const auto &node : forest->nodes)
            {
                states.push_back(si_->allocState());
                std::copy(node->q.data(), node->q.data() + node->q.size(),
                          states.back()->as<ob::RealVectorStateSpace::StateType>()->values);
                const ob::PlannerDataVertex vertex(states.back(), node->parent ? 0 : (forest->isStart ? 1 : 2));
                index[node.get()] = node->parent ? data.addVertex(vertex)
                                                 : (forest->isStart ? data.addStartVertex(vertex) : data.addGoalVertex(vertex));
            }
            for (const auto &node : forest->nodes)
                if (node->parent)
                    data.addEdge(index.at(node->parent), index.at(node.get()));
        }
        data.decoupleFromPlanner();
        for (ob::State *state : states)
            si_->freeState(state);
    }

    ob::PlannerStatus SlidingPlanner::solve(const ob::PlannerTerminationCondition &ptc)
    {
        const auto started = std::chrono::steady_clock::now();
        const auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(); };
        if (!isSetup())
            setup();
        result_ = PlanResult();  // a further call reports only itself; the forests grow on
        result_.planner = rootPolicyName(params_.policy);
        const bool fresh = startForest_->nodes.empty() && goalForest_->nodes.empty();
        if (bool startValid = true; fresh && !addGivenRoots(startValid))
        {
            result_.status = startValid ? "invalid goal" : "invalid start";
            return startValid ? ob::PlannerStatus::INVALID_GOAL : ob::PlannerStatus::INVALID_START;
        }
        // Planning from a state whose object already overhangs enough to be grasped (the end of a slide,
        // seen again): the plan is that state and its grasp. A sampled goal root could only be a detour.
        if (fresh && givenStart_)
        {
            Node *start = startForest_->roots.front();
            ++result_.stats.pairsChecked;
            const PairVerdict verdict = pairValidator_->check(start->q, start->q, rng_, ptc);
            if (verdict.valid)
            {
                extractPath(start, start, verdict, ptc);
                result_.planningTime = elapsed();
                return result_.status == "solved" ? ob::PlannerStatus::EXACT_SOLUTION : ob::PlannerStatus::TIMEOUT;
            }
            ++result_.stats.pairsRejected;
        }
        const bool ready = precomputeRoots(ptc);
        if (params_.policy != RootPolicy::Sampled)
            result_.stats.precomputeTime = elapsed();

        Forest *a = startForest_.get(), *b = goalForest_.get();
        const RobotModel &robot = *task_->robot;
        std::uniform_real_distribution<double> unit(0.0, 1.0);
        while (ready && !ptc)
        {
            ++result_.stats.iterations;
            // Given start states are where the arm is (planning from a state): the start forest draws no more.
            const bool mayAddRoot = !(a->isStart && givenStart_) &&
                                    (params_.policy == RootPolicy::Sampled || (params_.policy == RootPolicy::FixedStart && !a->isStart));
            if (mayAddRoot && canAddRoot(static_cast<int>(startForest_->roots.size()), static_cast<int>(goalForest_->roots.size()),
                                         params_.nStar, rng_))
                addRoot(*a, ptc);
            JointVector random(robot.dof());
            for (unsigned i = 0; i < robot.dof(); ++i)
                random(i) = robot.lowerLimits()(i) + unit(rng_) * (robot.upperLimits()(i) - robot.lowerLimits()(i));
            // A goal root drawn for a start root is worth a connection at once: the start forest's next
            // sample is that root (a goal bias; otherwise its tree waited for random samples nearby).
            if (a->isStart && pairedRoot_)
            {
                random = pairedRoot_->q;
                pairedRoot_ = nullptr;
            }
            bool reached = false;
            Node *extendedA = constrainedExtend(*a, a->nearestTo(random), random, reached);
            Node *extendedB = constrainedExtend(*b, nearestForConnection(*b, extendedA->q, *a, extendedA->root),
                                                extendedA->q, reached);
            if (reached)
            {
                ++result_.stats.connections;
                Node *startNode = a->isStart ? extendedA : extendedB, *goalNode = a->isStart ? extendedB : extendedA;
                const PairVerdict *verdict = validatePair(startNode, goalNode, ptc);
                if (verdict->valid && pathClear(startNode, goalNode))
                {
                    extractPath(startNode, goalNode, *verdict, ptc);
                    break;
                }
            }
            std::swap(a, b);
        }
        result_.stats.startRoots = static_cast<int>(startForest_->roots.size());
        result_.stats.goalRoots = static_cast<int>(goalForest_->roots.size());
        result_.stats.nodes = static_cast<long>(startForest_->nodes.size() + goalForest_->nodes.size());
        result_.planningTime = elapsed();
        return result_.status == "solved" ? ob::PlannerStatus::EXACT_SOLUTION : ob::PlannerStatus::TIMEOUT;
    }

    namespace
    {
        /// Fails loudly when no fingertip pose on the object has an IK solution at all. It counts against the
        /// time limit: cut by `ptc`, it says nothing, and the search that follows times out at once.
        void requireReachableObject(const SlidingTask &task, const PlannerParams &params, std::uint64_t seed,
                                    const ob::PlannerTerminationCondition &ptc)
        {
            std::mt19937_64 rng(seed);
            const Eigen::Vector2d centre = task.objectCom;
            IkOptions options = contactIkOptions(*task.robot);
            options.stop = [&ptc] { return ptc(); };
            for (int k = 0; k < 8; ++k)
            {
                Eigen::Isometry3d target = Eigen::Isometry3d::Identity();
                target.linear() = contactRotation(k * M_PI / 4, params.beta0);
                target.translation() << centre, task.surfaceZ - 0.5 * (params.dzMin + params.dzMax);
                Eigen::VectorXd q;
                if (task.robot->ik(target, Eigen::VectorXd(), rng, q, options) || ptc)
                    return;
            }
            std::ostringstream message;
            message << "the object is out of the robot's reach: no fingertip pose on it (pitch beta0 = " << params.beta0
                    << " rad, any yaw) has an inverse-kinematics solution";
            throw std::invalid_argument(message.str());
        }
    }  // namespace

    PlanResult planSliding(std::shared_ptr<const SlidingTask> task, const PlannerParams &params, std::uint64_t seed,
                           const ob::PlannerTerminationCondition &ptc, std::shared_ptr<const GraspMap> graspMap,
                           const std::optional<Eigen::VectorXd> &startConfig)
    {
        const auto started = std::chrono::steady_clock::now();
        params.validate();
        // On a convex table no edge has the centre of mass, com_margin inside it, nearer than com_margin,
        // and no point of the object lies further than `reach` from it: so no pair can overhang more.
        double reach = 0.0;
        for (const Eigen::Vector2d &vertex : task->hullXY)
            reach = std::max(reach, (vertex - task->objectCom).norm());
        if (task->table->isConvex() && params.uStar > reach - params.comMargin)
        {
            std::ostringstream message;
            message << "the object is too small for u_star = " << params.uStar << " m: no point of it lies more than "
                    << reach << " m from its centre of mass, which must stay com_margin = " << params.comMargin
                    << " m inside the table, so it overhangs an edge by at most " << reach - params.comMargin << " m";
            throw std::invalid_argument(message.str());
        }
        if (params.uStar > task->extent)
        {
            std::ostringstream message;
            message << "u_star = " << params.uStar << " m exceeds the object's largest extent (" << task->extent
                    << " m): no overhang can reach it";
            throw std::invalid_argument(message.str());
        }
        requireReachableObject(*task, params, seed, ptc);

        const RobotModel &robot = *task->robot;
        auto space = jointSpace(robot);
        auto si = std::make_shared<ob::SpaceInformation>(space);
        auto planner = std::make_shared<SlidingPlanner>(si, task, params, seed, std::move(graspMap));
        si->setup();
        auto pdef = std::make_shared<ob::ProblemDefinition>(si);
        if (startConfig)
        {
            if (startConfig->size() != robot.dof())
                throw InvalidStartConfig("start configuration has " + std::to_string(startConfig->size()) + " joints, the robot " +
                                         std::to_string(robot.dof()));
            ob::ScopedState<> start(space);
            std::copy(startConfig->data(), startConfig->data() + startConfig->size(),
                      start->as<ob::RealVectorStateSpace::StateType>()->values);
            pdef->addStartState(start);
        }
        planner->setProblemDefinition(pdef);
        planner->setup();
        const double setupTime = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
        if (planner->solve(ptc) == ob::PlannerStatus::INVALID_START)
            throw InvalidStartConfig("start configuration " + planner->givenRootProblem());
        PlanResult result = planner->result();
        result.stats.setupTime = setupTime;
        result.planningTime = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
        return result;
    }

}  // namespace slideplan
