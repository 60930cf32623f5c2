#pragma once
// A vertex widened to long double, for references computed beyond the precision under test.
#include <isin/vec.hpp>

template <class T>
isin::Vertex<long double> wide(const isin::Vertex<T>& p) {
    return {static_cast<long double>(p.x), static_cast<long double>(p.y), static_cast<long double>(p.z)};
}
