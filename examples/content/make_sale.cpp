// Generates sale.png, the demo content (run once; the PNG is committed):
//   g++ -std=c++17 make_sale.cpp $(pkg-config --cflags --libs opencv4) -o /tmp/make_sale
//   /tmp/make_sale sale.png
// Distinct corner marks (TL red, TR green, BR blue, BL white) make the corner order visible in
// projector.png and in the dry run's before/after views.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

int main(int argc, char** argv) {
  const cv::Size size(800, 500);
  cv::Mat img(size, CV_8UC3);
  for (int y = 0; y < size.height; ++y) {  // warm diagonal gradient
    for (int x = 0; x < size.width; ++x) {
      const double t = (x + y) / static_cast<double>(size.width + size.height);
      img.at<cv::Vec3b>(y, x) =
          cv::Vec3b(static_cast<uchar>(30 + 40 * t), static_cast<uchar>(60 + 120 * t), 230);
    }
  }
  cv::rectangle(img, cv::Rect(12, 12, size.width - 24, size.height - 24), cv::Scalar(255, 255, 255),
                6, cv::LINE_AA);
  const auto centred = [&](const std::string& text, int font, double scale, int thick, int y,
                           const cv::Scalar& colour) {
    int base = 0;
    const cv::Size t = cv::getTextSize(text, font, scale, thick, &base);
    cv::putText(img, text, cv::Point((size.width - t.width) / 2, y), font, scale,
                cv::Scalar(40, 40, 40), thick + 6, cv::LINE_AA);
    cv::putText(img, text, cv::Point((size.width - t.width) / 2, y), font, scale, colour, thick,
                cv::LINE_AA);
  };
  centred("SPRING", cv::FONT_HERSHEY_DUPLEX, 2.0, 3, 140, cv::Scalar(255, 255, 255));
  centred("SALE", cv::FONT_HERSHEY_TRIPLEX, 5.0, 12, 320, cv::Scalar(0, 240, 255));
  centred("-30% on everything", cv::FONT_HERSHEY_DUPLEX, 1.4, 2, 420, cv::Scalar(255, 255, 255));
  const int m = 40;
  const cv::Scalar marks[4] = {{0, 0, 255}, {0, 200, 0}, {255, 80, 0}, {255, 255, 255}};
  const cv::Point corners[4] = {
      {0, 0}, {size.width - m, 0}, {size.width - m, size.height - m}, {0, size.height - m}};
  for (int i = 0; i < 4; ++i)
    cv::rectangle(img, cv::Rect(corners[i], cv::Size(m, m)), marks[i], -1);
  return cv::imwrite(argc > 1 ? argv[1] : "sale.png", img) ? 0 : 1;
}
