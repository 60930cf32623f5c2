#pragma once
// Embree 3 set-up shared by the benchmarks that compare against it (vs_embree, scaling): an
// error callback that stops the run, and one triangle-soup geometry built at MEDIUM quality
// (vertex i of triangle k is vertex 3k + i — the triangles are a soup to Embree as to isin),
// with scene flags if asked (RTC_SCENE_FLAG_ROBUST: Embree's watertight mode, for checks).
#include <embree3/rtcore.h>

#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <vector>

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

} // namespace embree_scene
