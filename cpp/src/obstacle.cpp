#include "slideplan/obstacle.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace slideplan
{
    bool Obstacle::covers(const Eigen::Vector2d &point) const
    {
        switch (shape)
        {
            case Shape::Box:
            {
                const Eigen::Vector3d local = pose.inverse() * Eigen::Vector3d(point.x(), point.y(), pose.translation().z());
                return std::abs(local.x()) <= 0.5 * size.x() && std::abs(local.y()) <= 0.5 * size.y();
            }
            case Shape::Cylinder:
                return (point - pose.translation().head<2>()).norm() <= size.x();
            case Shape::Prism:
                for (std::size_t i = 0; i < polygon.size(); ++i)
                {
                    const Eigen::Vector2d edge = polygon[(i + 1) % polygon.size()] - polygon[i], to = point - polygon[i];
                    if (edge.x() * to.y() - edge.y() * to.x() < 0.0)
                        return false;
                }
                return true;
        }
        return false;
    }

    void Obstacle::validate(std::size_t index) const
    {
        const std::string name = "obstacle " + std::to_string(index);
        const bool positive = shape == Shape::Cylinder ? size.x() > 0 && size.y() > 0 : shape == Shape::Box ? (size.array() > 0).all() : size.z() > 0;
        if (!size.allFinite() || !pose.matrix().allFinite() || !positive)
            throw std::invalid_argument(name + ": size must be positive and finite");
        if (shape != Shape::Prism && std::abs(pose.linear()(2, 2) - 1.0) > 1e-9)
            throw std::invalid_argument(name + ": boxes and cylinders must stand upright (rotate about z only)");
        if (shape == Shape::Prism)
        {
            bool convex = polygon.size() >= 3;
            for (std::size_t i = 0; convex && i < polygon.size(); ++i)
            {
                const Eigen::Vector2d a = polygon[(i + 1) % polygon.size()] - polygon[i];
                const Eigen::Vector2d b = polygon[(i + 2) % polygon.size()] - polygon[(i + 1) % polygon.size()];
                convex = polygon[i].allFinite() && a.x() * b.y() - a.y() * b.x() > 0.0;
            }
            if (!convex)
                throw std::invalid_argument(name + ": the footprint must be a convex counter-clockwise polygon");
        }
    }

}  // namespace slideplan
