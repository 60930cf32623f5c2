#pragma once
// Every ray–triangle and ray–sphere method isin offers, as policies with a name, the per-triangle
// data it precomputes, and its test — so one harness can time and judge them all.
#include <isin/isin.hpp>

namespace methods {

template <class T>
struct AreaNote {
    static constexpr const char* name = "area-note";
    using Data = isin::Triangle<T>;
    static Data prepare(const isin::Triangle<T>& t) { return t; }
    static isin::Hit<T> test(const isin::Ray<T>& r, const Data& d) { return isin::intersect_area(r, d, T(0.005)); }
    static constexpr bool culls = false;
};
template <class T>
struct AreaRelative {
    static constexpr const char* name = "area-relative";
    using Data = isin::Triangle<T>;
    static Data prepare(const isin::Triangle<T>& t) { return t; }
    static isin::Hit<T> test(const isin::Ray<T>& r, const Data& d) { return isin::intersect_area(r, d); }
    static constexpr bool culls = false;
};
template <class T>
struct MollerTrumbore {
    static constexpr const char* name = "moller-trumbore";
    using Data = isin::Triangle<T>;
    static Data prepare(const isin::Triangle<T>& t) { return t; }
    static isin::Hit<T> test(const isin::Ray<T>& r, const Data& d) { return isin::intersect_moller_trumbore(r, d); }
    static constexpr bool culls = false;
};
template <class T>
struct MollerTrumboreCull {
    static constexpr const char* name = "moller-trumbore-cull";
    using Data = isin::Triangle<T>;
    static Data prepare(const isin::Triangle<T>& t) { return t; }
    static isin::Hit<T> test(const isin::Ray<T>& r, const Data& d) {
        return isin::intersect_moller_trumbore(r, d, true);
    }
    static constexpr bool culls = true;
};
template <class T>
struct Watertight {
    static constexpr const char* name = "watertight";
    using Data = isin::Triangle<T>;
    static Data prepare(const isin::Triangle<T>& t) { return t; }
    static isin::Hit<T> test(const isin::Ray<T>& r, const Data& d) { return isin::intersect_watertight(r, d); }
    static constexpr bool culls = false;
};
template <class T>
struct BaldwinWeber {
    static constexpr const char* name = "baldwin-weber";
    using Data = isin::BaldwinWeberTriangle<T>;
    static Data prepare(const isin::Triangle<T>& t) { return isin::baldwin_weber_transform(t); }
    static isin::Hit<T> test(const isin::Ray<T>& r, const Data& d) { return isin::intersect_baldwin_weber(r, d); }
    static constexpr bool culls = false;
};

// The vectorised structure-of-arrays kernel, judged one triangle at a time (a batch of one); its
// speed is measured on real batches (benchmarks/batch_timing.cpp).
template <class T>
struct MollerTrumboreBatch {
    static constexpr const char* name = "moller-trumbore-batch";
    using Data = isin::TriangleBatch<T>;
    static Data prepare(const isin::Triangle<T>& t) { return Data(std::vector<isin::Triangle<T>>{t}); }
    static isin::Hit<T> test(const isin::Ray<T>& r, const Data& d) { return d.nearest(r); }
    static constexpr bool culls = false;
};

template <class T>
struct SphereNote {
    static constexpr const char* name = "sphere-note";
    static isin::Hit<T> test(const isin::Ray<T>& r, const isin::Sphere<T>& s) { return isin::intersect_note(r, s); }
};
template <class T>
struct SphereNoteFix {
    static constexpr const char* name = "sphere-note-fix";
    static isin::Hit<T> test(const isin::Ray<T>& r, const isin::Sphere<T>& s) {
        return isin::intersect_note(r, s, T(0.001));
    }
};
template <class T>
struct SphereIsin {
    static constexpr const char* name = "sphere-isin";
    static isin::Hit<T> test(const isin::Ray<T>& r, const isin::Sphere<T>& s) { return isin::intersect(r, s); }
};
template <class T>
struct SphereQuadratic {
    static constexpr const char* name = "sphere-quadratic";
    static isin::Hit<T> test(const isin::Ray<T>& r, const isin::Sphere<T>& s) {
        return isin::intersect_quadratic(r, s);
    }
};
template <class T>
struct SphereRtg {
    static constexpr const char* name = "sphere-rtg";
    static isin::Hit<T> test(const isin::Ray<T>& r, const isin::Sphere<T>& s) { return isin::intersect_rtg(r, s); }
};

} // namespace methods
