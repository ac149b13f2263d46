/// \file mesh.hpp
/// Collision meshes of a URDF: resolving `package://`, `file://` and relative file names, and reading
/// STL, OBJ and DAE files (assimp, as the ROS ecosystem does) into triangles.
#pragma once

#include "slideplan/robot_model.hpp"

#include <memory>
#include <string>
#include <vector>

namespace slideplan
{
    /// The file a URDF mesh URI names. `package://NAME/rest` resolves to `DIR/NAME/rest`, or to
    /// `DIR/rest` when DIR itself is named NAME, for the first DIR of `packageDirs` where it exists;
    /// `file://` URIs are absolute; other names are relative to `directory`.
    /// \throws std::invalid_argument starting with `where` if the file does not exist.
    std::string resolveMeshUri(const std::string &uri, const std::string &directory,
                               const std::vector<std::string> &packageDirs, const std::string &where);

    /// The triangles of every mesh in the file, scaled per axis, in the file's frame.
    /// \throws std::invalid_argument starting with `where` for an unreadable, unsupported or empty file.
    std::shared_ptr<const TriangleMesh> loadMesh(const std::string &file, const Eigen::Vector3d &scale,
                                                 const std::string &where);

    /// A hand link's mesh whose convex hull is more than this many times its own volume is checked as
    /// its triangles (an FCL BVH) rather than as the hull: the hull would fill a concavity the object
    /// enters, e.g. the gap between jaws modelled with their housing in one mesh (the Unitree Z1's
    /// gripperStator: 1.82). Most hand and arm meshes of example-robot-data are below 1.5.
    constexpr double kConcaveHullRatio = 1.5;

    /// The volume a closed triangle mesh encloses (divergence theorem), whatever its orientation;
    /// meaningless, often near 0, for an open mesh.
    double meshVolume(const TriangleMesh &mesh);

    /// The convex hull (qhull) of a mesh's vertices, triangles facing outward: the collision shape of
    /// a link. \throws std::invalid_argument starting with `where` if the mesh has no volume.
    std::shared_ptr<const TriangleMesh> convexHull(const TriangleMesh &mesh, const std::string &where);

}  // namespace slideplan
