#pragma once
// doctest::Approx takes a double; this spells the float → double widening out, so that tests of
// float code compile warning-free under -Wdouble-promotion.
#include <doctest/doctest.h>

template <class T>
doctest::Approx approx(T value) {
    return doctest::Approx(static_cast<double>(value));
}
