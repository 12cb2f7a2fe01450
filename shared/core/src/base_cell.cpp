#include <terrain/base_cell.h>

namespace terrain {

double baseHeight(const CellCorners& c, Diagonal d, double u, double v) {
    const double h00 = c.h00;
    const double h10 = c.h10;
    const double h01 = c.h01;
    const double h11 = c.h11;
    if (d == Diagonal::kMain) {
        if (u >= v)
            return h00 + (h10 - h00) * u + (h11 - h10) * v;
        return h00 + (h11 - h01) * u + (h01 - h00) * v;
    }
    if (u + v <= 1.0)
        return h00 + (h10 - h00) * u + (h01 - h00) * v;
    return h11 + (h01 - h11) * (1.0 - u) + (h10 - h11) * (1.0 - v);
}

Gradient baseGradient(const CellCorners& c, Diagonal d, double u, double v) {
    const double h00 = c.h00;
    const double h10 = c.h10;
    const double h01 = c.h01;
    const double h11 = c.h11;
    if (d == Diagonal::kMain) {
        if (u >= v)
            return {h10 - h00, h11 - h10};
        return {h11 - h01, h01 - h00};
    }
    if (u + v <= 1.0)
        return {h10 - h00, h01 - h00};
    return {h11 - h01, h11 - h10};
}

} // namespace terrain
