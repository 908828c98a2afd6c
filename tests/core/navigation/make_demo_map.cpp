// Regenerates maps/malaga_campus.{yaml,png} from MRPT's 2006-MalagaCampus.gridmap.gz (see
// maps/SOURCE.md): crops the corridor part of the campus and turns the SLAM grid's graded
// probabilities into the three classes map_server files hold.
//
//   make_demo_map /usr/share/mrpt/datasets/2006-MalagaCampus.gridmap.gz maps/malaga_campus.yaml
#include <mrpt/maps/COccupancyGridMap2D.h>

#include <cmath>
#include <exception>
#include <iostream>

#include "demo_map_crop.hpp"
#include "projtour/navigation/occupancy_map.hpp"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: make_demo_map SOURCE.gridmap.gz OUT.yaml\n";
    return 2;
  }
  try {
    const auto source = projtour::navigation::load_occupancy_grid(argv[1]);
    const auto cropped = projtour::demo_map::crop_and_classify(*source);
    projtour::navigation::save_occupancy_grid_yaml(cropped, argv[2]);
    std::cout << "wrote " << argv[2] << ": " << cropped.getSizeX() << " x " << cropped.getSizeY()
              << " cells of " << cropped.getResolution() << " m\n";
  } catch (const std::exception& e) {
    std::cerr << "make_demo_map: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
