#include "slideplan/grasp_map.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace slideplan
{
    Eigen::Isometry3d sideGraspPose(const Eigen::Vector2d &point, const EdgeQuery &edge, double z)
    {
        const Eigen::Vector3d approach(-edge.outwardNormal.x(), -edge.outwardNormal.y(), 0.0);
        const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
        Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
        pose.linear().col(0) = up.cross(approach);
        pose.linear().col(1) = up;
        pose.linear().col(2) = approach;
        pose.translation() << point, z;
        return pose;
    }

    IkOptions graspIkOptions(const PlannerParams &params)
    {
        IkOptions options;
        options.rotationTolerance << params.graspTiltTolerance, params.graspYawTolerance, params.graspRollTolerance;
        return options;
    }

    bool liftableGraspIk(const SlidingTask &task, const PlannerParams &params, const Eigen::Isometry3d &grasp,
                         const Eigen::VectorXd &seed, int attempts, std::mt19937_64 &rng, Eigen::VectorXd &solution,
                         int abandonAfter)
    {
        const RobotModel &robot = *task.robot;
        IkOptions options = graspIkOptions(params);
        options.maxAttempts = attempts;
        options.abandonAfter = abandonAfter;
        // Asked of every solution, so that the restarts look for another posture rather than give up: the
        // lift as the execution makes it (slideplan.motions.straight_line calls straightLine too), from the
        // seed only (one attempt: a restart would jump branches).
        if (params.liftCheck)
            options.accept = [&](const Eigen::VectorXd &q) {
                IkOptions near = graspIkOptions(params);
                near.maxAttempts = 1;
                return straightLine(robot, q, grasp, Eigen::Vector3d(0.0, 0.0, params.graspLift), near, 0, task.graspLink,
                                    task.graspOffset)
                    .has_value();
            };
        return robot.ikForLink(task.graspLink, grasp, seed, rng, solution, options, task.graspOffset);
    }

    GraspMap::GraspMap(std::shared_ptr<const RobotModel> robot, std::shared_ptr<const SupportSurface> table,
                       std::string graspLink, const Eigen::Isometry3d &graspOffset, double thickness,
                       const PlannerParams &params)
      : thickness_(micrometres(thickness)), params_(params)
    {
        if (!robot || !table || !std::isfinite(thickness) || thickness < 0.0)
            throw std::invalid_argument("a grasp map needs a robot, a table and a thickness >= 0");
        if (robot->linkIndex(graspLink) < 0)  // as SlidingTask::make says it
            throw std::invalid_argument("[hand] grasp_link '" + graspLink + "' is not a link of the robot");
        geometry_.robot = std::move(robot);
        geometry_.table = std::move(table);
        geometry_.graspLink = std::move(graspLink);
        geometry_.graspOffset = graspOffset;
    }

    GraspMap::GraspMap(const SlidingTask &task, const PlannerParams &params)
      : GraspMap(task.robot, task.table, task.graspLink, task.graspOffset, task.thickness(), params)
    {
    }

    std::pair<int, long> GraspMap::stretch(const EdgeQuery &edge) const
    {
        const Eigen::Vector2d start = geometry_.table->vertices().row(edge.edge).transpose();
        return {edge.edge, static_cast<long>(std::floor((edge.closest - start).norm() / kStretch))};
    }

    bool GraspMap::reachable(const EdgeQuery &edge) const
    {
        return lookUp(edge).size() > 0;
    }

    Eigen::VectorXd GraspMap::graspSeed(const EdgeQuery &edge) const
    {
        return lookUp(edge);
    }

    Eigen::VectorXd GraspMap::lookUp(const EdgeQuery &edge) const
    {
        return answer(stretch(edge));
    }

    Eigen::VectorXd GraspMap::answer(const std::pair<int, long> &stretch) const
    {
        {
            const std::lock_guard<std::mutex> lock(mutex_);
            if (const auto known = known_.find(stretch); known != known_.end())
                return known->second;
        }
        // Probed without the lock: two plans may probe the same stretch at once, with the same answer.
        Eigen::VectorXd result = probe(stretch);
        const std::lock_guard<std::mutex> lock(mutex_);
        known_.emplace(stretch, result);
        return result;
    }

    long GraspMap::stretchCount(int edge) const
    {
        const SupportSurface &table = *geometry_.table;
        const long vertices = static_cast<long>(table.vertices().rows());
        if (edge < 0 || edge >= vertices)
            throw std::invalid_argument("edge " + std::to_string(edge) + " is not an edge of the table");
        const Eigen::Vector2d a = table.vertices().row(edge).transpose();
        const Eigen::Vector2d b = table.vertices().row((edge + 1) % vertices).transpose();
        return static_cast<long>(std::floor((b - a).norm() / kStretch)) + 1;
    }

    Eigen::Isometry3d GraspMap::stretchGrasp(const std::pair<int, long> &stretch) const
    {
        const SupportSurface &table = *geometry_.table;
        if (stretch.second < 0 || stretch.second >= stretchCount(stretch.first))
            throw std::invalid_argument("cell " + std::to_string(stretch.second) + " is not a stretch of edge " +
                                        std::to_string(stretch.first));
        const Eigen::Vector2d a = table.vertices().row(stretch.first).transpose();
        const Eigen::Vector2d b = table.vertices().row((stretch.first + 1) % table.vertices().rows()).transpose();
        const Eigen::Vector2d direction = (b - a).normalized();
        EdgeQuery edge;
        edge.edge = stretch.first;
        edge.closest = a + std::min((stretch.second + 0.5) * kStretch, (b - a).norm()) * direction;
        edge.outwardNormal = Eigen::Vector2d(direction.y(), -direction.x());  // as SupportSurface::closestEdge
        const double beyond = std::max(params_.graspStandoff, 0.5 * params_.uStar);
        return sideGraspPose(edge.closest + beyond * edge.outwardNormal, edge, table.height() + 0.5 * thickness_);
    }

    Eigen::VectorXd GraspMap::probe(const std::pair<int, long> &stretch) const
    {
        // Stretches between two anchors (every kAnchor-th and the edge's last) take their anchors' word
        // where both are unreachable, and else try their grasps too: unreachable stretches come in runs,
        // and each costs every restart below. The eight scenes' maps (four tables for the WAM, two
        // each for the Panda and the UR5; the T42's and the paper's conditions) lose no reachable stretch
        // against probing each one (gain 2), and whole maps cost 1.9-3.2x less on the square, triangle and
        // long tables (the round tables' short edges are mostly anchors: 0.93-1.0x).
        std::vector<Eigen::VectorXd> seeds;
        const long last = stretchCount(stretch.first) - 1;
        if (stretch.second % kAnchor != 0 && stretch.second < last)
        {
            const long before = stretch.second - stretch.second % kAnchor;
            for (const long anchor : {before, std::min(before + kAnchor, last)})
                if (Eigen::VectorXd grasp = answer({stretch.first, anchor}); grasp.size() > 0)
                    seeds.push_back(std::move(grasp));
            if (seeds.empty())
                return {};
        }
        // Side grasps at table height are a thin part of the workspace: about one restart in 5 succeeds,
        // and an unreachable stretch costs every restart. So a restart still 0.1 (m + rad) off after
        // kAbandon iterations is given up (WAM + T42, four tables: 95% of the restarts that fail, 7% of
        // those that would converge), which pays for twice the restarts: against 20 restarts of 100
        // iterations, the maps of the four tables lose no reachable stretch, gain 8 that were missed, and
        // cost 2.2-2.9x less (the triangle table's 154 stretches: 405 -> 139 ms).
        constexpr int kAbandon = 30;
        const int restarts = params_.graspFlip ? 20 : 40;
        const Eigen::Isometry3d grasp = stretchGrasp(stretch);
        std::mt19937_64 rng(0x5eed0000u + 1000003u * static_cast<std::uint64_t>(stretch.first) +
                            static_cast<std::uint64_t>(stretch.second));
        std::vector<Eigen::Isometry3d> poses{grasp};
        if (params_.graspFlip)
            poses.push_back(grasp * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()));
        Eigen::VectorXd solution;
        for (const Eigen::Isometry3d &pose : poses)
            if (liftableGraspIk(geometry_, params_, pose, Eigen::VectorXd(), restarts, rng, solution, kAbandon))
                return solution;
        // The anchors' grasps last, so that a stretch the restarts reach keeps their grasp (the seed of its
        // grasps while planning: with the anchors' postures, triangle-table plans took 25 iterations, not 10).
        for (const Eigen::Isometry3d &pose : poses)
            for (const Eigen::VectorXd &seed : seeds)
                if (liftableGraspIk(geometry_, params_, pose, seed, 1, rng, solution, kAbandon))
                    return solution;
        return {};
    }

    bool GraspMap::fits(const SlidingTask &task, const PlannerParams &params) const
    {
        const SupportSurface &mine = *geometry_.table, &theirs = *task.table;
        return task.robot == geometry_.robot && task.graspLink == geometry_.graspLink &&
               task.graspOffset.isApprox(geometry_.graspOffset, 0.0) &&
               std::abs(micrometres(task.thickness()) - thickness_) < 1.5e-6 &&  // rounding may straddle
               theirs.height() == mine.height() && theirs.vertices().rows() == mine.vertices().rows() &&
               theirs.vertices() == mine.vertices() &&
               std::all_of(parameters().begin(), parameters().end(), [&](const ParameterSpec &spec) {
                   return !spec.graspMap || spec.get(params) == spec.get(params_);
               });
    }

    std::size_t GraspMap::probed() const
    {
        const std::lock_guard<std::mutex> lock(mutex_);
        return known_.size();
    }

    std::vector<GraspMap::Entry> GraspMap::entries() const
    {
        const std::lock_guard<std::mutex> lock(mutex_);
        std::vector<Entry> all;
        all.reserve(known_.size());
        for (const auto &[stretch, grasp] : known_)
            all.push_back({stretch.first, stretch.second, grasp});
        return all;
    }

    void GraspMap::remember(const std::vector<Entry> &entries)
    {
        const long edges = static_cast<long>(geometry_.table->vertices().rows());
        const long dof = static_cast<long>(geometry_.robot->dof());
        for (const Entry &entry : entries)
            if (entry.edge < 0 || entry.edge >= edges || entry.cell < 0 ||
                (entry.grasp.size() != 0 && (entry.grasp.size() != dof || !entry.grasp.allFinite())))
                throw std::invalid_argument("grasp map entry (edge " + std::to_string(entry.edge) + ", cell " +
                                            std::to_string(entry.cell) + ") does not fit this robot and table");
        const std::lock_guard<std::mutex> lock(mutex_);
        for (const Entry &entry : entries)
            known_.emplace(std::make_pair(entry.edge, entry.cell), entry.grasp);
    }

}  // namespace slideplan
