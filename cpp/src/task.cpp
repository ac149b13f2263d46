#include "slideplan/task.hpp"

#include <sstream>
#include <stdexcept>

namespace slideplan
{
    SlidingTask SlidingTask::make(std::shared_ptr<const RobotModel> robot, std::shared_ptr<const SupportSurface> table,
                                  std::vector<BoxObstacle> obstacles, std::vector<std::string> contactLinks,
                                  const Eigen::Matrix<double, Eigen::Dynamic, 3> &objectPoints,
                                  const Eigen::Vector2d &objectCom)
    {
        if (!robot || !table)
            throw std::invalid_argument("a robot and a table are required");
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
        task.objectXY = objectPoints.leftCols<2>();
        task.surfaceZ = objectPoints.col(2).mean();
        task.objectCom = objectCom;
        if (!(task.thickness() > 0.0))
            throw std::invalid_argument("object cloud lies at or below the table top (mean z - table height = " +
                                        std::to_string(task.thickness()) + " m)");
        long outside = 0;
        for (int i = 0; i < task.objectXY.rows(); ++i)
            outside += !task.table->contains(task.objectXY.row(i).transpose());
        if (outside > 0)
        {
            std::ostringstream message;
            message << "object is not on the table: " << outside << " of " << task.objectXY.rows()
                    << " points lie outside the table polygon";
            throw std::invalid_argument(message.str());
        }
        if (!task.table->contains(objectCom))
            throw std::invalid_argument("object centre of mass lies outside the table polygon");
        return task;
    }

    double SlidingTask::objectExtent() const
    {
        double extent = 0.0;
        for (int i = 0; i < objectXY.rows(); ++i)
            for (int j = i + 1; j < objectXY.rows(); ++j)
                extent = std::max(extent, (objectXY.row(i) - objectXY.row(j)).norm());
        return extent;
    }

}  // namespace slideplan
