// Limit position and derivatives at (face, u, v) with OpenSubdiv's Bfr (3.5), in double
// precision: the reference for `SurfacePoints` (benchmarks/osd_surface_points.py).
//
// Reads from stdin:
//   scheme(catmark|loop) boundary(edge_only|edge_and_corner) creasing(uniform|chaikin) approx_level
//   V F C K N
//   V lines: x y z
//   F lines: n i_1 ... i_n
//   C lines: a b sharpness
//   K lines: v sharpness
//   N lines: face u v
// Writes N lines: P(3) Du(3) Dv(3) Duu(3) Duv(3) Dvv(3), and "invalid" for a face Bfr
// has no surface for. A negative approx_level -L instead refines the mesh uniformly L
// levels (Far::PrimvarRefiner) and writes the refined vertices, one per line.
#include <opensubdiv/bfr/refinerSurfaceFactory.h>
#include <opensubdiv/bfr/surface.h>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

using namespace OpenSubdiv;

int main() {
    std::string scheme, boundary, creasing;
    int approx;
    std::cin >> scheme >> boundary >> creasing >> approx;
    int V, F, C, K, N;
    std::cin >> V >> F >> C >> K >> N;
    std::vector<double> points(3 * V);
    for (auto &x : points) std::cin >> x;
    std::vector<int> sizes(F), indices;
    for (int f = 0; f < F; ++f) {
        std::cin >> sizes[f];
        for (int k = 0; k < sizes[f]; ++k) {
            int i;
            std::cin >> i;
            indices.push_back(i);
        }
    }
    std::vector<int> creases(2 * C);
    std::vector<float> crease_weights(C);
    for (int c = 0; c < C; ++c) std::cin >> creases[2 * c] >> creases[2 * c + 1] >> crease_weights[c];
    std::vector<int> corners(K);
    std::vector<float> corner_weights(K);
    for (int k = 0; k < K; ++k) std::cin >> corners[k] >> corner_weights[k];

    Far::TopologyDescriptor desc;
    desc.numVertices = V;
    desc.numFaces = F;
    desc.numVertsPerFace = sizes.data();
    desc.vertIndicesPerFace = indices.data();
    desc.numCreases = C;
    desc.creaseVertexIndexPairs = creases.data();
    desc.creaseWeights = crease_weights.data();
    desc.numCorners = K;
    desc.cornerVertexIndices = corners.data();
    desc.cornerWeights = corner_weights.data();

    Sdc::Options options;
    options.SetVtxBoundaryInterpolation(boundary == "edge_only"
                                            ? Sdc::Options::VTX_BOUNDARY_EDGE_ONLY
                                            : Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
    options.SetCreasingMethod(creasing == "chaikin" ? Sdc::Options::CREASE_CHAIKIN
                                                    : Sdc::Options::CREASE_UNIFORM);
    Sdc::SchemeType type = scheme == "loop" ? Sdc::SCHEME_LOOP : Sdc::SCHEME_CATMARK;
    using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
    Far::TopologyRefiner *refiner = Factory::Create(desc, Factory::Options(type, options));
    if (!refiner) {
        std::fprintf(stderr, "OpenSubdiv rejected the mesh\n");
        return 1;
    }

    if (approx < 0) {
        int levels = -approx;
        refiner->RefineUniform(Far::TopologyRefiner::UniformOptions(levels));
        struct Point {
            double p[3];
            void Clear() { p[0] = p[1] = p[2] = 0; }
            void AddWithWeight(Point const &o, double w) {
                for (int k = 0; k < 3; ++k) p[k] += w * o.p[k];
            }
        };
        std::vector<Point> all(refiner->GetNumVerticesTotal());
        for (int v = 0; v < V; ++v)
            for (int k = 0; k < 3; ++k) all[v].p[k] = points[3 * v + k];
        Far::PrimvarRefinerReal<double> primvar(*refiner);
        Point *src = all.data();
        for (int level = 1; level <= levels; ++level) {
            Point *dst = src + refiner->GetLevel(level - 1).GetNumVertices();
            primvar.Interpolate(level, src, dst);
            src = dst;
        }
        for (int v = 0; v < refiner->GetLevel(levels).GetNumVertices(); ++v)
            std::printf("%.17g %.17g %.17g\n", src[v].p[0], src[v].p[1], src[v].p[2]);
        delete refiner;
        return 0;
    }

    Bfr::SurfaceFactory::Options factory_options;
    factory_options.SetApproxLevelSmooth(approx).SetApproxLevelSharp(approx);
    Bfr::RefinerSurfaceFactory<> factory(*refiner, factory_options);
    Bfr::Surface<double> surface;
    int current = -1;
    std::vector<double> patch_points;
    for (int n = 0; n < N; ++n) {
        int face;
        double uv[2];
        std::cin >> face >> uv[0] >> uv[1];
        if (face != current) {
            current = face;
            if (!factory.InitVertexSurface(face, &surface)) {
                surface.Clear();
            } else {
                patch_points.resize(3 * surface.GetNumPatchPoints());
                surface.PreparePatchPoints(points.data(), 3, patch_points.data(), 3);
            }
        }
        if (!surface.IsValid()) {
            std::printf("invalid\n");
            continue;
        }
        double out[18];
        surface.Evaluate(uv, patch_points.data(), 3, out, out + 3, out + 6, out + 9, out + 12,
                         out + 15);
        for (int k = 0; k < 18; ++k) std::printf("%.17g%c", out[k], k == 17 ? '\n' : ' ');
    }
    delete refiner;
    return 0;
}
