// CGAL's uniform subdivision of an OFF mesh, timed: the baseline of
// benchmarks/bench_surface_build.py, which compiles this file once with
// `g++ -O2 -DNDEBUG -std=c++17` (CGAL is header-only; Debian's libcgal-dev).
//
//     cgal_subdivide SCHEME LEVELS REPEATS MESH.off
//
// SCHEME is CatmullClark, Loop or DooSabin. The mesh is read once into a
// CGAL::Surface_mesh (not timed); then, after one untimed warm-up, each of REPEATS
// runs copies it and subdivides the copy LEVELS times in place
// (CGAL::Subdivision_method_3, number_of_iterations(LEVELS)), timed with
// std::chrono::steady_clock. Prints one JSON line: the median and every time in
// seconds, and the vertex and face counts of the subdivided mesh.

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/subdivision_method_3.h>
#include <CGAL/version.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

using Kernel = CGAL::Simple_cartesian<double>;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;

namespace {

void subdivide(Mesh& mesh, const std::string& scheme, int levels) {
  namespace SM = CGAL::Subdivision_method_3;
  const auto iterations = CGAL::parameters::number_of_iterations(levels);
  if (scheme == "CatmullClark") {
    SM::CatmullClark_subdivision(mesh, iterations);
  } else if (scheme == "Loop") {
    SM::Loop_subdivision(mesh, iterations);
  } else {
    SM::DooSabin_subdivision(mesh, iterations);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5) {
    std::cerr << "usage: " << argv[0] << " CatmullClark|Loop|DooSabin LEVELS REPEATS MESH.off\n";
    return 2;
  }
  const std::string scheme = argv[1];
  const int levels = std::atoi(argv[2]);
  const int repeats = std::atoi(argv[3]);
  if (scheme != "CatmullClark" && scheme != "Loop" && scheme != "DooSabin") {
    std::cerr << "unknown scheme " << scheme << "\n";
    return 2;
  }
  if (levels < 0 || repeats < 1) {
    std::cerr << "LEVELS must be >= 0 and REPEATS >= 1\n";
    return 2;
  }
  Mesh base;
  std::ifstream in(argv[4]);
  if (!in || !(in >> base) || base.is_empty()) {
    std::cerr << "could not read a surface mesh from " << argv[4] << "\n";
    return 1;
  }
  if (scheme == "Loop" && !CGAL::is_triangle_mesh(base)) {
    std::cerr << "Loop subdivision needs a triangle mesh\n";
    return 1;
  }

  Mesh out = base;  // the untimed warm-up; its counts are reported
  subdivide(out, scheme, levels);
  std::vector<double> seconds;
  for (int r = 0; r < repeats; ++r) {
    const auto start = std::chrono::steady_clock::now();
    Mesh mesh = base;
    subdivide(mesh, scheme, levels);
    const auto stop = std::chrono::steady_clock::now();
    seconds.push_back(std::chrono::duration<double>(stop - start).count());
  }
  std::vector<double> sorted = seconds;
  std::sort(sorted.begin(), sorted.end());
  const std::size_t n = sorted.size();
  const double median = n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);

  std::cout.precision(9);
  std::cout << "{\"cgal\": \"" << CGAL_VERSION_STR << "\", \"scheme\": \"" << scheme
            << "\", \"levels\": " << levels << ", \"median_seconds\": " << median
            << ", \"seconds\": [";
  for (std::size_t i = 0; i < n; ++i) std::cout << (i ? ", " : "") << seconds[i];
  std::cout << "], \"in_vertices\": " << base.number_of_vertices()
            << ", \"in_faces\": " << base.number_of_faces()
            << ", \"vertices\": " << out.number_of_vertices()
            << ", \"faces\": " << out.number_of_faces() << "}" << std::endl;
  return 0;
}
