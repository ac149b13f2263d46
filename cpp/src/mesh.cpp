#include "slideplan/mesh.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <filesystem>
#include <functional>
#include <libqhullcpp/Qhull.h>
#include <libqhullcpp/QhullError.h>
#include <libqhullcpp/QhullFacetList.h>
#include <libqhullcpp/QhullVertexSet.h>
#include <map>
#include <stdexcept>

namespace slideplan
{
    namespace fs = std::filesystem;

    std::string resolveMeshUri(const std::string &uri, const std::string &directory,
                               const std::vector<std::string> &packageDirs, const std::string &where)
    {
        const std::string package = "package://", file = "file://";
        if (uri.rfind(package, 0) == 0)
        {
            const std::string rest = uri.substr(package.size());
            const std::string name = rest.substr(0, rest.find('/'));
            const std::string inside = rest.find('/') == std::string::npos ? "" : rest.substr(rest.find('/') + 1);
            for (const std::string &dir : packageDirs)
            {
                fs::path base = fs::path(dir).lexically_normal();
                if (base.filename().empty())
                    base = base.parent_path();  // "share/NAME/" names NAME too
                if (fs::is_regular_file(base / name / inside))
                    return (base / name / inside).string();
                if (base.filename() == name && fs::is_regular_file(base / inside))
                    return (base / inside).string();
            }
            throw std::invalid_argument(where + ": cannot resolve package '" + name +
                                        "' (add its parent directory to [robot] package_dirs or ROS_PACKAGE_PATH, or "
                                        "install the Python package that ships it)");
        }
        const fs::path path = uri.rfind(file, 0) == 0 ? fs::path(uri.substr(file.size()))
                              : fs::path(uri).is_absolute() || directory.empty() ? fs::path(uri)
                                                                                  : fs::path(directory) / uri;
        if (!fs::is_regular_file(path))
            throw std::invalid_argument(where + ": mesh file '" + path.string() + "' does not exist");
        return path.string();
    }

    std::shared_ptr<const TriangleMesh> loadMesh(const std::string &file, const Eigen::Vector3d &scale,
                                                 const std::string &where)
    {
        Assimp::Importer importer;
        // Keep the file's own units: URDF meshes are in metres times <mesh scale>; COLLADA's <unit>
        // is applied by assimp to the root node transform, which the walk below includes. No vertex
        // joining: the hull and the BVH need none, and joining took most of the load time.
        const aiScene *scene = importer.ReadFile(file, aiProcess_Triangulate);
        if (!scene || !scene->mRootNode)
            throw std::invalid_argument(where + ": cannot read mesh '" + file + "' (" + importer.GetErrorString() + ")");
        auto mesh = std::make_shared<TriangleMesh>();
        const std::function<void(const aiNode *, const aiMatrix4x4 &)> walk = [&](const aiNode *node, const aiMatrix4x4 &parent) {
            const aiMatrix4x4 transform = parent * node->mTransformation;
            for (unsigned m = 0; m < node->mNumMeshes; ++m)
            {
                const aiMesh *part = scene->mMeshes[node->mMeshes[m]];
                const int first = static_cast<int>(mesh->vertices.size());
                for (unsigned v = 0; v < part->mNumVertices; ++v)
                {
                    const aiVector3D p = transform * part->mVertices[v];
                    mesh->vertices.emplace_back(scale.x() * p.x, scale.y() * p.y, scale.z() * p.z);
                }
                for (unsigned f = 0; f < part->mNumFaces; ++f)
                    if (part->mFaces[f].mNumIndices == 3)
                        mesh->triangles.emplace_back(first + static_cast<int>(part->mFaces[f].mIndices[0]),
                                                     first + static_cast<int>(part->mFaces[f].mIndices[1]),
                                                     first + static_cast<int>(part->mFaces[f].mIndices[2]));
            }
            for (unsigned c = 0; c < node->mNumChildren; ++c)
                walk(node->mChildren[c], transform);
        };
        walk(scene->mRootNode, aiMatrix4x4());
        if (mesh->triangles.empty())
            throw std::invalid_argument(where + ": mesh '" + file + "' has no triangles");
        for (const auto &v : mesh->vertices)
            if (!v.allFinite())
                throw std::invalid_argument(where + ": mesh '" + file + "' has non-finite vertices");
        return mesh;
    }

    double meshVolume(const TriangleMesh &mesh)
    {
        double sixfold = 0.0;
        for (const Eigen::Vector3i &t : mesh.triangles)
            sixfold += mesh.vertices[t.x()].dot(mesh.vertices[t.y()].cross(mesh.vertices[t.z()]));
        return std::abs(sixfold) / 6.0;
    }

    std::shared_ptr<const TriangleMesh> convexHull(const TriangleMesh &mesh, const std::string &where)
    {
        // Each distinct point once: meshes read without vertex joining repeat a point per triangle
        // corner, and qhull's time grows with its input (a third of a Jaco2's load time).
        std::vector<std::array<double, 3>> points;
        points.reserve(mesh.vertices.size());
        for (const Eigen::Vector3d &v : mesh.vertices)
            points.push_back({v.x(), v.y(), v.z()});
        std::sort(points.begin(), points.end());
        points.erase(std::unique(points.begin(), points.end()), points.end());
        std::vector<double> coordinates;
        coordinates.reserve(3 * points.size());
        for (const auto &p : points)
            coordinates.insert(coordinates.end(), p.begin(), p.end());
        auto hull = std::make_shared<TriangleMesh>();
        try
        {
            // Qt: triangulated output, so every facet is a triangle FCL's Convex takes as a face.
            orgQhull::Qhull qhull;
            qhull.runQhull("", 3, static_cast<int>(points.size()), coordinates.data(), "Qt");
            std::map<int, int> index;  // qhull point id -> hull vertex
            Eigen::Vector3d centre = Eigen::Vector3d::Zero();
            for (const orgQhull::QhullFacet &facet : qhull.facetList())
            {
                Eigen::Vector3i triangle;
                int corner = 0;
                for (const orgQhull::QhullVertex &vertex : facet.vertices())
                {
                    const int id = vertex.point().id();
                    if (!index.count(id))
                    {
                        index[id] = static_cast<int>(hull->vertices.size());
                        hull->vertices.emplace_back(points[static_cast<std::size_t>(id)].data());
                        centre += hull->vertices.back();
                    }
                    if (corner < 3)
                        triangle(corner++) = index[id];
                }
                hull->triangles.push_back(triangle);
            }
            centre /= static_cast<double>(hull->vertices.size());
            for (Eigen::Vector3i &t : hull->triangles)  // outward: the normal points away from an interior point
            {
                const auto &a = hull->vertices[t.x()], &b = hull->vertices[t.y()], &c = hull->vertices[t.z()];
                if ((b - a).cross(c - a).dot(a - centre) < 0)
                    std::swap(t.y(), t.z());
            }
        }
        catch (const orgQhull::QhullError &error)
        {
            throw std::invalid_argument(where + ": the mesh has no volume (its convex hull is undefined: " +
                                        std::string(error.what()).substr(0, 80) + ")");
        }
        return hull;
    }

}  // namespace slideplan
