// make_office_map OUT.png: the proving ground's fourth map (maps/SOURCE.md), an office floor
// drawn in code rather than scanned. 24 x 16 m at 0.05 m a cell: 0.2 m outer walls, a 2.4 m
// corridor along the middle with two 0.4 m pillars, three 5.6 x 6.4 m rooms to each side behind
// 0.12 m partition walls with 1.2 m doors, and a lobby open to the corridor at the east end.
// The cells outside the outer walls are unknown, as a laser would leave them.
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace {

constexpr double kCellM = 0.05;
constexpr unsigned char kFree = 254, kOccupied = 0, kUnknown = 205;

// A rectangle in metres (x right, y up from the map's lower-left corner) as image pixels.
cv::Rect cells(double x0_m, double y0_m, double x1_m, double y1_m, int rows) {
  const int c0 = static_cast<int>(x0_m / kCellM + 0.5), c1 = static_cast<int>(x1_m / kCellM + 0.5);
  const int r0 = rows - static_cast<int>(y1_m / kCellM + 0.5);
  const int r1 = rows - static_cast<int>(y0_m / kCellM + 0.5);
  return {c0, r0, c1 - c0, r1 - r0};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_office_map OUT.png\n");
    return 2;
  }
  constexpr double kWidthM = 24.0, kHeightM = 16.0;
  const int cols = static_cast<int>(kWidthM / kCellM), rows = static_cast<int>(kHeightM / kCellM);
  cv::Mat map(rows, cols, CV_8UC1, cv::Scalar(kUnknown));
  const auto fill = [&](double x0, double y0, double x1, double y1, unsigned char v) {
    map(cells(x0, y0, x1, y1, rows)) = v;
  };
  // The building's outline: a wall 0.2 m thick around free space.
  fill(0.5, 0.5, 23.5, 15.5, kOccupied);
  fill(0.7, 0.7, 23.3, 15.3, kFree);
  // Partitions: the corridor (y 6.8-9.2) between two rows of rooms, rooms 5.6 m wide up to
  // x = 17.5; east of it the lobby spans the floor.
  for (const double y : {6.8, 9.2}) fill(0.7, y - 0.06, 17.5, y + 0.06, kOccupied);
  for (const double x : {6.3, 11.9, 17.5}) {
    fill(x - 0.06, 0.7, x + 0.06, 6.8, kOccupied);
    fill(x - 0.06, 9.2, x + 0.06, 15.3, kOccupied);
  }
  // Doors: 1.2 m in each room's corridor wall, and the lobby's openings to the rooms' row ends.
  for (const double x : {2.5, 8.1, 13.7}) {
    fill(x, 6.7, x + 1.2, 6.9, kFree);
    fill(x, 9.1, x + 1.2, 9.3, kFree);
  }
  fill(17.4, 6.8, 17.6, 9.2, kFree);  // the corridor opens into the lobby
  // Two pillars in the corridor.
  for (const double x : {5.0, 12.0}) fill(x - 0.2, 7.8, x + 0.2, 8.2, kOccupied);
  if (!cv::imwrite(argv[1], map)) {
    std::fprintf(stderr, "make_office_map: %s: cannot write\n", argv[1]);
    return 1;
  }
  return 0;
}
