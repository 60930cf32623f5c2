#pragma once
// Embree 3 set-up shared by the benchmarks that compare against it (vs_embree, scaling): an
// error callback that stops the run, and one triangle-soup geometry built at MEDIUM quality
// (vertex i of triangle k is vertex 3k + i — the triangles are a soup to Embree as to isin),
// with scene flags if asked (RTC_SCENE_FLAG_ROBUST: Embree's watertight mode, for checks).
#include <embree3/rtcore.h>

#include <algorithm>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <vector>

#include <isin/bvh/tree.hpp>
#include <isin/triangle.hpp>

namespace embree_scene {

inline void on_error(void*, RTCError code, const char* message) {
    std::fprintf(stderr, "Embree error %d: %s\n", int(code), message ? message : "");
    std::exit(3);
}

inline RTCScene make(RTCDevice device, const std::vector<isin::Triangle<float>>& tris,
                     RTCSceneFlags flags = RTC_SCENE_FLAG_NONE) {
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneFlags(scene, flags);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(geometry, RTC_BUILD_QUALITY_MEDIUM);
    const std::size_t n = tris.size();
    auto* vertices = static_cast<float*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * n));
    auto* indices = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), n));
    for (std::size_t k = 0; k < n; ++k) {
        const isin::Vertex<float>* v[3] = {&tris[k].v0, &tris[k].v1, &tris[k].v2};
        for (std::size_t i = 0; i < 3; ++i) {
            vertices[9 * k + 3 * i] = v[i]->x, vertices[9 * k + 3 * i + 1] = v[i]->y,
                                 vertices[9 * k + 3 * i + 2] = v[i]->z;
            indices[3 * k + i] = unsigned(3 * k + i);
        }
    }
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene, geometry);
    rtcReleaseGeometry(geometry);
    rtcCommitScene(scene);
    return scene;
}

// The SAH cost (isin::BvhCost) of the tree Embree's own builder makes over the triangles' boxes
// (rtcBuildBVH at MEDIUM quality: binned SAH, as for its scenes), 8 wide, leaves of 1 to 8
// triangles, the leaf cost counted per block of 8 (sahBlockSize), a node and a block weighed
// alike: isin's build's limits and cost model. Embree's scenes keep their trees to themselves;
// this gives a reference for the quality of isin's trees from the same builder family.
namespace sah_detail {
struct Node {
    bool leaf = false;
    unsigned count = 0; // children, or triangles of a leaf
    Node* child[8] = {};
    RTCBounds bounds[8] = {};
};
inline void* create_node(RTCThreadLocalAllocator alloc, unsigned count, void*) {
    auto* n = new (rtcThreadLocalAlloc(alloc, sizeof(Node), 16)) Node;
    n->count = count;
    return n;
}
inline void set_children(void* node, void** children, unsigned count, void*) {
    for (unsigned k = 0; k < count; ++k) static_cast<Node*>(node)->child[k] = static_cast<Node*>(children[k]);
}
inline void set_bounds(void* node, const RTCBounds** bounds, unsigned count, void*) {
    for (unsigned k = 0; k < count; ++k) static_cast<Node*>(node)->bounds[k] = *bounds[k];
}
inline void* create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive*, std::size_t count, void*) {
    auto* n = new (rtcThreadLocalAlloc(alloc, sizeof(Node), 16)) Node;
    n->leaf = true, n->count = unsigned(count);
    return n;
}
inline double area(const RTCBounds& b, double scale) {
    const double e[3] = {(double(b.upper_x) - double(b.lower_x)) / scale,
                         (double(b.upper_y) - double(b.lower_y)) / scale,
                         (double(b.upper_z) - double(b.lower_z)) / scale};
    return e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
}
inline void add(const Node& n, double root_area, double scale, isin::BvhCost& c) {
    for (unsigned k = 0; k < n.count; ++k) {
        const Node& kid = *n.child[k];
        const double p = std::min(1.0, area(n.bounds[k], scale) / root_area);
        if (kid.leaf) {
            c.leaf_visits += p, c.primitive_tests += p * double(kid.count);
        } else {
            c.node_visits += p;
            add(kid, root_area, scale, c);
        }
    }
}
} // namespace sah_detail

inline isin::BvhCost builder_sah(RTCDevice device, const std::vector<isin::Triangle<float>>& tris) {
    std::vector<RTCBuildPrimitive> prims;
    prims.reserve(tris.size());
    for (std::size_t k = 0; k < tris.size(); ++k) {
        const isin::Triangle<float>& t = tris[k];
        RTCBuildPrimitive p;
        p.lower_x = std::min({t.v0.x, t.v1.x, t.v2.x}), p.upper_x = std::max({t.v0.x, t.v1.x, t.v2.x});
        p.lower_y = std::min({t.v0.y, t.v1.y, t.v2.y}), p.upper_y = std::max({t.v0.y, t.v1.y, t.v2.y});
        p.lower_z = std::min({t.v0.z, t.v1.z, t.v2.z}), p.upper_z = std::max({t.v0.z, t.v1.z, t.v2.z});
        p.geomID = 0, p.primID = unsigned(k);
        prims.push_back(p);
    }
    RTCBVH bvh = rtcNewBVH(device);
    RTCBuildArguments args = rtcDefaultBuildArguments();
    args.buildQuality = RTC_BUILD_QUALITY_MEDIUM;
    args.maxBranchingFactor = 8;
    args.maxDepth = 64;
    args.sahBlockSize = 8;
    args.minLeafSize = 1;
    args.maxLeafSize = 8;
    args.traversalCost = 1.0f;
    args.intersectionCost = 1.0f;
    args.bvh = bvh;
    args.primitives = prims.data();
    args.primitiveCount = prims.size();
    args.primitiveArrayCapacity = prims.size();
    args.createNode = sah_detail::create_node;
    args.setNodeChildren = sah_detail::set_children;
    args.setNodeBounds = sah_detail::set_bounds;
    args.createLeaf = sah_detail::create_leaf;
    isin::BvhCost c;
    const auto* root = static_cast<const sah_detail::Node*>(rtcBuildBVH(&args));
    if (root && !root->leaf) {
        RTCBounds all = root->bounds[0]; // the root's box: its children's together
        for (unsigned k = 1; k < root->count; ++k) {
            const RTCBounds& b = root->bounds[k];
            all.lower_x = std::min(all.lower_x, b.lower_x), all.upper_x = std::max(all.upper_x, b.upper_x);
            all.lower_y = std::min(all.lower_y, b.lower_y), all.upper_y = std::max(all.upper_y, b.upper_y);
            all.lower_z = std::min(all.lower_z, b.lower_z), all.upper_z = std::max(all.upper_z, b.upper_z);
        }
        const double scale =
            std::max({double(all.upper_x) - double(all.lower_x), double(all.upper_y) - double(all.lower_y),
                      double(all.upper_z) - double(all.lower_z)});
        c.node_visits = 1.0;
        sah_detail::add(*root, sah_detail::area(all, scale), scale, c);
    }
    rtcReleaseBVH(bvh);
    return c;
}

} // namespace embree_scene
