#pragma once
/// isin — bounding volume hierarchies, behind one header:
///  - bvh/box.hpp       Box<T>, the bounds a Bvh is built from
///  - bvh/tree.hpp      BvhTree<T>: 8-wide nodes and leaves (ranges of primitive indices), refit
///  - bvh/build_context.hpp  BuildContext: scratch memory a caller keeps across rebuilds
///  - bvh/build.hpp     build_bvh: binned SAH on several threads, collapsed to 8-wide nodes for the
///                      least SAH cost (Ylitie, Karras & Laine 2017); any input builds
///  - bvh/traverse.hpp  traverse<Visit>: the caller's leaf test for the nearest, any or all hits
///  - bvh/packet.hpp   walk_packets: 16 coherent rays at once (or two such packets), one
///                      interval test per node
///  - bvh/triangles.hpp the triangle leaves: blocks of 8, the watertight test on 8 lanes
///                      (triangles_avx2.hpp: its AVX2 + FMA form)
///  - bvh/triangle_bvh.hpp  Bvh<T>: all of it for triangles, with culling and skip filters
///  - bvh/closest_point.hpp Bvh::closest_point: the nearest surface point, nearest box first
///  - bvh/crossings.hpp Bvh::count_hits: crossings counted once through shared edges and vertices
///
///     isin::Bvh<float> bvh{triangles};          // std::vector<isin::Triangle<float>> or isin::Mesh<float>
///     if (auto h = bvh.intersect(ray)) use(h.t, h.u, h.v, h.primitive);
///     bool shadowed = bvh.occluded(shadow_ray, distance_to_light);
///     bvh.intersect(rays, count, hits);   // a stream: 4×4 tiles of rays go as packets
///
///     // any primitive: a tree over their boxes, and a leaf test of your own
///     auto tree = isin::build_bvh<float>(n, [&](std::size_t i) { return box_of(i); });
///     float t = inf;
///     isin::traverse<isin::Visit::nearest>(tree, ray, t, [&](std::uint32_t leaf, float& t_max) {
///         const auto& l = tree.leaves()[leaf];
///         for (auto j = l.first; j < l.first + l.count; ++j) test(tree.primitives()[j], t_max);
///         return false;
///     });
#include "bvh/box.hpp"
#include "bvh/build.hpp"
#include "bvh/build_context.hpp"
#include "bvh/closest_point.hpp"
#include "bvh/crossings.hpp"
#include "bvh/packet.hpp"
#include "bvh/traverse.hpp"
#include "bvh/tree.hpp"
#include "bvh/triangle_bvh.hpp"
#include "bvh/triangles.hpp"
