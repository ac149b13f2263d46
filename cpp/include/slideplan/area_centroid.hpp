/// \file area_centroid.hpp
/// The centre of mass of a uniform thin object known by points of its top surface (the CoM that
/// pair validation keeps com_margin inside the table, paper IV-C.1).
#pragma once

#include <Eigen/Core>

#include <array>
#include <vector>

namespace slideplan
{
    /// Row-major list of 2-D points, one point per row.
    using Points2 = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

    /// The area centroid of the region the points cover, whatever their density (a mean leans towards
    /// where points are denser: the bundled outlines' boundary rings put the crescent's mean 3.2 mm off).
    ///
    /// The region is an alpha shape: the Delaunay triangles whose longest edge is at most 1.5 times the
    /// local point spacing at their corners (the mean distance to a point's 6 nearest neighbours), so a
    /// grid keeps its diagonals, gaps of two spacings are left out, and concave outlines and holes wider
    /// than that are followed. Clouds over 20,000 points are thinned first to one point per 1 mm cell (the
    /// region stays the same to a fraction of a millimetre, at a tenth of the cost).
    ///
    /// \returns the area centroid, or the points' mean when they cover no area (fewer than 3, or all on
    ///          one line).
    /// \throws std::invalid_argument if a coordinate is not finite or there are no points.
    Eigen::Vector2d areaCentroid(const Points2 &points);

    /// The region areaCentroid finds: its triangles, area (m^2, 0 when the points cover none) and area centroid.
    struct PlateRegion
    {
        std::vector<std::array<Eigen::Vector2d, 3>> triangles;
        double area{0.0};
        Eigen::Vector2d centroid{Eigen::Vector2d::Zero()};
    };

    /// areaCentroid's region itself: the material of a plate known by points (the grasp model's patch,
    /// hold_model.hpp, is the part of it between the pads; its mass is density x thickness x area).
    /// \throws std::invalid_argument as areaCentroid.
    PlateRegion plateRegion(const Points2 &points);
}  // namespace slideplan
