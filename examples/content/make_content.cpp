// Generates the demo content images (run once; the PNGs are committed):
//   g++ -std=c++17 make_content.cpp $(pkg-config --cflags --libs opencv4) -o /tmp/make_content
//   /tmp/make_content .        # writes ./sale.png, ./sign.png, ./pillar.png, ./lunch.png and
//                              # ./lunch.avi (missions/all_day.yaml's rotating lunch content)
// sale.png is bit-for-bit the image make_sale.cpp made, which this program replaces.
// Every poster carries the same corner marks (TL red, TR green, BR blue, BL white) so the corner
// order is visible in projector.png and in the dry run's before/after views.
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

namespace {

struct Line {
  std::string text;
  int font;
  double scale;
  int thickness;
  int baseline_y;  // px from the top
  cv::Scalar colour;
};

struct Band {  // a solid strip behind text, e.g. a banner
  cv::Rect rect;
  cv::Scalar colour;
};

struct Poster {
  std::string file;
  cv::Size size;
  cv::Vec3d colour_from, colour_to;  // BGR, diagonal gradient top-left -> bottom-right
  std::vector<Band> bands;
  std::vector<Line> lines;
  int mark_px;
};

cv::Mat draw(const Poster& p) {
  cv::Mat img(p.size, CV_8UC3);
  for (int y = 0; y < p.size.height; ++y) {
    for (int x = 0; x < p.size.width; ++x) {
      const double t = (x + y) / static_cast<double>(p.size.width + p.size.height);
      cv::Vec3b& px = img.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c) {
        px[c] = static_cast<uchar>(p.colour_from[c] + (p.colour_to[c] - p.colour_from[c]) * t);
      }
    }
  }
  for (const auto& band : p.bands) cv::rectangle(img, band.rect, band.colour, -1, cv::LINE_AA);
  cv::rectangle(img, cv::Rect(12, 12, p.size.width - 24, p.size.height - 24),
                cv::Scalar(255, 255, 255), 6, cv::LINE_AA);
  for (const auto& l : p.lines) {  // centred, with a dark outline for contrast on any background
    int base = 0;
    const cv::Size t = cv::getTextSize(l.text, l.font, l.scale, l.thickness, &base);
    const cv::Point at((p.size.width - t.width) / 2, l.baseline_y);
    cv::putText(img, l.text, at, l.font, l.scale, cv::Scalar(40, 40, 40), l.thickness + 6,
                cv::LINE_AA);
    cv::putText(img, l.text, at, l.font, l.scale, l.colour, l.thickness, cv::LINE_AA);
  }
  const int m = p.mark_px;
  const cv::Scalar marks[4] = {{0, 0, 255}, {0, 200, 0}, {255, 80, 0}, {255, 255, 255}};
  const cv::Point corners[4] = {
      {0, 0}, {p.size.width - m, 0}, {p.size.width - m, p.size.height - m}, {0, p.size.height - m}};
  for (int i = 0; i < 4; ++i)
    cv::rectangle(img, cv::Rect(corners[i], cv::Size(m, m)), marks[i], -1);
  return img;
}

std::vector<Poster> posters() {
  const cv::Scalar white(255, 255, 255), yellow(0, 240, 255);
  const int duplex = cv::FONT_HERSHEY_DUPLEX, triplex = cv::FONT_HERSHEY_TRIPLEX;
  return {
      // 800 x 500 landscape, warm: the bunny's sale.
      {"sale.png",
       {800, 500},
       {30, 60, 230},
       {70, 180, 230},
       {},
       {{"SPRING", duplex, 2.0, 3, 140, white},
        {"SALE", triplex, 5.0, 12, 320, yellow},
        {"-30% on everything", duplex, 1.4, 2, 420, white}},
       40},
      // 1200 x 900 (4:3) landscape, cool: the box-shaped sign.
      {"sign.png",
       {1200, 900},
       {150, 70, 20},
       {200, 150, 40},
       {{cv::Rect(0, 520, 1200, 130), cv::Scalar(40, 40, 200)}},
       {{"WELCOME TO OUR", duplex, 2.2, 3, 200, white},
        {"OPEN DAY", triplex, 5.2, 12, 430, yellow},
        {"Saturday 10:00 - 16:00", duplex, 2.0, 3, 610, white},
        {"labs - talks - robot demos", duplex, 1.6, 2, 760, white}},
       60},
      // 600 x 1300 portrait, green with a red banner: the pillar wrap.
      {"pillar.png",
       {600, 1300},
       {60, 120, 10},
       {120, 200, 60},
       {{cv::Rect(0, 230, 600, 280), cv::Scalar(30, 30, 210)}},
       {{"just in", duplex, 1.8, 3, 170, white},
        {"NEW", triplex, 5.0, 14, 440, yellow},
        {"the", duplex, 2.0, 3, 680, white},
        {"SPRING", triplex, 2.6, 6, 800, white},
        {"COLLECTION", duplex, 1.7, 3, 900, white},
        {"level 1", duplex, 1.6, 2, 1120, yellow}},
       50},
      // 800 x 500 landscape, orange: the lunch-time menu (missions/all_day.yaml).
      {"lunch.png",
       {800, 500},
       {20, 120, 240},
       {40, 60, 160},
       {{cv::Rect(0, 330, 800, 90), cv::Scalar(40, 120, 40)}},
       {{"TODAY'S LUNCH", duplex, 1.8, 3, 130, white},
        {"MENU", triplex, 4.6, 11, 290, yellow},
        {"11:30 - 14:00  cafe, level 0", duplex, 1.2, 2, 390, white}},
       40},
  };
}

// A 4 s loop of the lunch poster at half size with a band sweeping across it: small enough to
// commit (MJPG), moving enough to see the video path work.
bool write_lunch_clip(const std::filesystem::path& file, const cv::Mat& poster) {
  cv::Mat half;
  cv::resize(poster, half, cv::Size(poster.cols / 2, poster.rows / 2), 0, 0, cv::INTER_AREA);
  cv::VideoWriter writer(file.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 2.5,
                         half.size());
  if (!writer.isOpened()) return false;
  writer.set(cv::VIDEOWRITER_PROP_QUALITY, 60);
  for (int i = 0; i < 10; ++i) {
    cv::Mat frame = half.clone();
    const int x = i * half.cols / 10;
    cv::rectangle(frame, cv::Rect(x, half.rows - 40, half.cols / 10, 20), cv::Scalar(0, 240, 255),
                  -1);
    writer.write(frame);
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  const std::filesystem::path dir = argc > 1 ? argv[1] : ".";
  for (const Poster& p : posters()) {
    const cv::Mat image = draw(p);
    if (!cv::imwrite((dir / p.file).string(), image)) return 1;
    if (p.file == "lunch.png" && !write_lunch_clip(dir / "lunch.avi", image)) return 1;
  }
  return 0;
}
