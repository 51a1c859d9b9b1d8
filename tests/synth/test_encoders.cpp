// The dataset's file encoders: PNG (synth/png.h), which any reader must decode to exactly the pixels
// given, and depth EXR (synth/exr.h), whose bytes must depend on the pixels only.
#include "core/error.h"
#include "synth/exr.h"
#include "synth/png.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <ctime>
#include <stdexcept>
#include <string>
#include <vector>

namespace facesynth::synth {
namespace {

cv::Mat decoded(const std::string& png) {
    const std::vector<uchar> bytes(png.begin(), png.end());
    return cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
}

bool same_pixels(const cv::Mat& a, const cv::Mat& b) {
    return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

// An OpenEXR input stream over bytes in memory (the library reads files or streams only).
class BytesInputStream final : public Imf::IStream {
public:
    explicit BytesInputStream(const std::string& bytes) : Imf::IStream("depth.exr"), bytes_(bytes) {}
    bool read(char c[], int n) override {
        const auto count = static_cast<std::size_t>(n);
        if (position_ + count > bytes_.size()) throw std::runtime_error("read past the end of the EXR bytes");
        std::memcpy(c, bytes_.data() + position_, count);
        position_ += count;
        return position_ < bytes_.size();
    }
    std::uint64_t tellg() override { return position_; }
    void seekg(std::uint64_t position) override { position_ = std::min<std::size_t>(position, bytes_.size()); }

private:
    const std::string& bytes_;
    std::size_t position_ = 0;
};

// Smooth gradients (what the Up filter is for), noise, and flat areas, as in a rendered sample.
cv::Mat test_image(int width, int height, int type, int seed) {
    cv::Mat image(height, width, type);
    cv::RNG rng(static_cast<std::uint64_t>(seed));
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width * image.channels(); ++x)
            image.ptr<uchar>(y)[x] = static_cast<uchar>(x < width ? (3 * x + 5 * y) & 0xff : rng.uniform(0, 256));
    if (width > 4 && height > 4) image(cv::Rect(1, 1, width / 2, height / 2)).setTo(cv::Scalar::all(77));
    return image;
}

TEST(PngEncoder, DecodesToTheSamePixelsAtEveryLevel) {
    for (const int level : {0, 1, 6, 9}) {
        PngEncoder encoder(level);
        for (const auto& [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {3, 7}, {256, 256}, {301, 17}}) {
            const cv::Mat rgb = test_image(width, height, CV_8UC3, width + level);
            const cv::Mat grey = test_image(width, height, CV_8UC1, height + level);
            const cv::Mat rgb_back = decoded(encoder.encode(rgb, "rgb"));
            ASSERT_FALSE(rgb_back.empty()) << "level " << level << ", " << width << "x" << height;
            cv::Mat rgb_back_in_rgb;
            cv::cvtColor(rgb_back, rgb_back_in_rgb, cv::COLOR_BGR2RGB);  // OpenCV decodes to B G R
            EXPECT_TRUE(same_pixels(rgb, rgb_back_in_rgb)) << "level " << level << ", " << width << "x" << height;
            EXPECT_TRUE(same_pixels(grey, decoded(encoder.encode(grey, "grey")))) << "level " << level << ", " << width << "x" << height;
        }
    }
}

TEST(PngEncoder, CompressesAndIsDeterministic) {
    const cv::Mat rgb = test_image(256, 256, CV_8UC3, 1);
    PngEncoder fast(1), stored(0), other(1);
    const std::string a = fast.encode(rgb, "a");
    EXPECT_EQ(a, other.encode(rgb, "b"));
    EXPECT_EQ(a, fast.encode(rgb, "c"));  // reused buffers leave nothing behind
    EXPECT_LT(a.size(), stored.encode(rgb, "d").size());
    EXPECT_GT(stored.encode(rgb, "d").size(), rgb.total() * 3);  // level 0 stores the pixels
}

TEST(PngEncoder, RefusesOtherImageTypesAndLevelsNamingThem) {
    PngEncoder encoder(1);
    try {
        (void)encoder.encode(cv::Mat(4, 4, CV_32FC1, cv::Scalar(0)), "s00000007");
        FAIL() << "float image accepted";
    } catch (const core::Error& e) {
        EXPECT_NE(std::string(e.what()).find("s00000007"), std::string::npos) << e.what();
    }
    EXPECT_THROW((void)encoder.encode(cv::Mat(), "empty"), core::Error);
    EXPECT_THROW((void)encoder.encode(cv::Mat(4, 4, CV_8UC4, cv::Scalar::all(0)), "rgba"), core::Error);
    EXPECT_THROW(PngEncoder(10), core::Error);
    EXPECT_THROW(PngEncoder(-1), core::Error);
}

TEST(DepthExr, RoundTripsAndCarriesNoTimeStamp) {
    cv::Mat depth(5, 7, CV_32FC1, cv::Scalar(0));
    for (int y = 1; y < 4; ++y)
        for (int x = 2; x < 6; ++x) depth.at<float>(y, x) = 400.0f + 1.25f * static_cast<float>(x) + 0.001f * static_cast<float>(y);
    const std::string exr = encode_depth_exr(depth, "s00000003");
    // A time stamp in the header (OpenImageIO, which wrote these files before, added one unless told
    // otherwise) made the same sample's file differ between runs.
    char today[16];
    const std::time_t now = std::time(nullptr);
    std::tm utc{}, local{};
    ::gmtime_r(&now, &utc);
    ::localtime_r(&now, &local);
    for (const std::tm* t : {&utc, &local}) {
        std::strftime(today, sizeof today, "%Y:%m:%d", t);
        EXPECT_EQ(exr.find(today), std::string::npos) << "the EXR header holds the date " << today;
    }
    EXPECT_EQ(exr, encode_depth_exr(depth, "again"));

    BytesInputStream stream(exr);
    Imf::InputFile input(stream);
    const auto window = input.header().dataWindow();
    ASSERT_EQ(window.max.x - window.min.x + 1, depth.cols);
    ASSERT_EQ(window.max.y - window.min.y + 1, depth.rows);
    ASSERT_NE(input.header().channels().findChannel("Z"), nullptr);
    EXPECT_EQ(input.header().compression(), Imf::ZIP_COMPRESSION);
    cv::Mat back(depth.size(), CV_32FC1, cv::Scalar(-1));
    Imf::FrameBuffer frame;
    frame.insert("Z", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(back.ptr<float>()), sizeof(float), sizeof(float) * static_cast<std::size_t>(back.cols)));
    input.setFrameBuffer(frame);
    input.readPixels(window.min.y, window.max.y);
    EXPECT_EQ(cv::norm(depth, back, cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace facesynth::synth
