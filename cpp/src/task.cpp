#include "slideplan/task.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

namespace slideplan
{
    SlidingTask SlidingTask::make(std::shared_ptr<const RobotModel> robot, std::shared_ptr<const SupportSurface> table,
                                  std::vector<Obstacle> obstacles, std::vector<std::string> contactLinks,
                                  std::string graspLink, const Eigen::Isometry3d &graspOffset,
                                  const Eigen::Matrix<double, Eigen::Dynamic, 3> &objectPoints,
                                  const Eigen::Vector2d &objectCom, bool mayOverhang)
    {
        if (!robot || !table)
            throw std::invalid_argument("a robot and a table are required");
        if (robot->linkIndex(graspLink) < 0)
            throw std::invalid_argument("[hand] grasp_link '" + graspLink + "' is not a link of the robot");
        if (!graspOffset.matrix().allFinite())
            throw std::invalid_argument("[hand] grasp_offset is not finite");
        if (objectPoints.rows() < 3)
            throw std::invalid_argument("object point cloud needs at least 3 points, got " +
                                        std::to_string(objectPoints.rows()));
        if (!objectPoints.allFinite() || !objectCom.allFinite())
            throw std::invalid_argument("object point cloud has NaN or infinite coordinates");
        SlidingTask task;
        task.robot = std::move(robot);
        task.table = std::move(table);
        task.obstacles = std::move(obstacles);
        task.contactLinks = std::move(contactLinks);
        task.graspLink = std::move(graspLink);
        task.graspOffset = graspOffset;
        task.objectXY = objectPoints.leftCols<2>();
        task.surfaceZ = objectPoints.col(2).mean();
        task.objectCom = objectCom;
        if (!(task.thickness() > 0.0))
            throw std::invalid_argument("object cloud lies at or below the table top (mean z - table height = " +
                                        std::to_string(task.thickness()) + " m)");
        long outside = 0;
        for (int i = 0; i < task.objectXY.rows(); ++i)
            outside += !task.table->contains(task.objectXY.row(i).transpose());
        if (outside > 0 && !mayOverhang)
        {
            std::ostringstream message;
            message << "object is not on the table: " << outside << " of " << task.objectXY.rows()
                    << " points lie outside the table polygon";
            throw std::invalid_argument(message.str());
        }
        if (!task.table->contains(objectCom))
            throw std::invalid_argument("object centre of mass lies outside the table polygon");

        // A footprint without area (collinear or coincident points) has no overhang to grasp: say so
        // instead of planning until the time limit.
        std::vector<Eigen::Vector2d> points(static_cast<std::size_t>(task.objectXY.rows()));
        for (int i = 0; i < task.objectXY.rows(); ++i)
            points[static_cast<std::size_t>(i)] = task.objectXY.row(i).transpose();
        const std::vector<Eigen::Vector2d> hull = convexHull(std::move(points));
        task.hullXY = hull;
        Polygon2 hullPolygon(static_cast<long>(hull.size()), 2);
        for (std::size_t i = 0; i < hull.size(); ++i)
        {
            hullPolygon.row(static_cast<long>(i)) = hull[i].transpose();
            for (std::size_t j = 0; j < i; ++j)
                task.extent = std::max(task.extent, (hull[i] - hull[j]).norm());
        }
        constexpr double kMinWidth = 1e-3;  // m: thinner than a millimetre across is a line, not a plate
        const double area = hull.size() < 3 ? 0.0 : signedArea(hullPolygon);
        if (!(area >= kMinWidth * task.extent) || task.extent == 0.0)
        {
            std::ostringstream message;
            message << "object cloud is degenerate: its points lie on a line or a point (footprint " << area * 1e6
                    << " mm^2 over an extent of " << task.extent * 1e3 << " mm; a thin object needs an area)";
            throw std::invalid_argument(message.str());
        }

        std::map<std::pair<long, long>, std::pair<Eigen::Vector2d, int>> cells;  // sorted: a reproducible order
        for (int i = 0; i < task.objectXY.rows(); ++i)
        {
            const Eigen::Vector2d p = task.objectXY.row(i).transpose();
            auto &cell = cells[{static_cast<long>(std::floor(p.x() / kFootprintCell)), static_cast<long>(std::floor(p.y() / kFootprintCell))}];
            if (cell.second == 0)
                cell.first.setZero();
            cell.first += p;
            ++cell.second;
        }
        for (std::size_t i = 0; i < task.obstacles.size(); ++i)
        {
            const Obstacle &obstacle = task.obstacles[i];
            obstacle.validate(i);
            const std::string name = "obstacle " + std::to_string(i);
            if (obstacle.bottom() < task.table->height() - 1e-3)
                throw std::invalid_argument(name + " reaches into the table top (its bottom is " +
                                            std::to_string(task.table->height() - obstacle.bottom()) + " m below it)");
            const Eigen::Vector2d centre = obstacle.shape == Obstacle::Shape::Prism
                                               ? Eigen::Map<const Eigen::Matrix2Xd>(obstacle.polygon.front().data(), 2,
                                                                                     static_cast<long>(obstacle.polygon.size()))
                                                     .rowwise()
                                                     .mean()
                                               : Eigen::Vector2d(obstacle.pose.translation().head<2>());
            if (!task.table->contains(centre))
                throw std::invalid_argument(name + " is off the table (its centre is outside the table polygon)");
        }
        task.footprintXY.resize(static_cast<long>(cells.size()), 2);
        task.footprintWeight.resize(static_cast<long>(cells.size()));
        long row = 0;
        for (const auto &[key, cell] : cells)
        {
            task.footprintXY.row(row) = (cell.first / cell.second).transpose();
            task.footprintWeight(row++) = cell.second;
        }
        if (const int hit = task.overlappedObstacle(PlanarMotion()); hit >= 0)
            throw std::invalid_argument("obstacles[" + std::to_string(hit) + "] overlaps the object where it lies");
        return task;
    }

    int SlidingTask::overlappedObstacle(const PlanarMotion &motion) const
    {
        const Eigen::Isometry2d move = motion.transform();
        for (std::size_t index = 0; index < obstacles.size(); ++index)
        {
            const Obstacle &obstacle = obstacles[index];
            if (obstacle.bottom() >= surfaceZ)
                continue;  // above the object: only the arm has to avoid it
            for (int i = 0; i < footprintXY.rows(); ++i)
                if (obstacle.covers(move * footprintXY.row(i).transpose()))
                    return static_cast<int>(index);
            for (const Eigen::Vector2d &vertex : hullXY)
                if (obstacle.covers(move * vertex))
                    return static_cast<int>(index);
        }
        return -1;
    }

}  // namespace slideplan
