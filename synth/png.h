#pragma once
// PNG files of dataset images, written for speed: every row uses PNG's "Up" filter (the difference
// to the row above) and the stream is compressed with libdeflate. At level 1 that is about 3x faster
// than libpng's adaptive filtering with zlib and the files are about 9 % smaller (docs/synth.md
// "Speed"); any PNG reader decodes them to the same pixels.
#include <opencv2/core.hpp>

#include <memory>
#include <string>
#include <string_view>
#include <vector>

struct libdeflate_compressor;

namespace facesynth::synth {

// One per thread (a compressor is not shareable); buffers are reused between images.
class PngEncoder {
public:
    // `level`: deflate level, 0 (stored, no filter) to 9; 1 is the fastest that compresses. Throws
    // core::Error outside that range.
    explicit PngEncoder(int level);
    ~PngEncoder();
    PngEncoder(PngEncoder&&) noexcept;
    PngEncoder& operator=(PngEncoder&&) noexcept;
    PngEncoder(const PngEncoder&) = delete;
    PngEncoder& operator=(const PngEncoder&) = delete;

    // The bytes of a PNG file holding `image`: 8-bit grey (CV_8UC1) or RGB (CV_8UC3, stored in R G B
    // order as given). Throws core::Error starting with `context` for any other type.
    [[nodiscard]] std::string encode(const cv::Mat& image, const std::string& context);

private:
    struct FreeCompressor {
        void operator()(libdeflate_compressor* compressor) const;
    };
    std::unique_ptr<libdeflate_compressor, FreeCompressor> compressor_;
    int level_;
    std::vector<unsigned char> filtered_;  // the rows with their filter bytes
    std::vector<unsigned char> deflated_;  // the zlib stream
};

// A dataset image (CV_8UC3, R G B) as the bytes of a file of `format`: "png" through `png`, or "jpg"
// at `jpeg_quality`. Throws core::Error starting with `context` when encoding fails.
[[nodiscard]] std::string encode_image(const cv::Mat& rgb, std::string_view format, int jpeg_quality, PngEncoder& png,
                                       const std::string& context);

}  // namespace facesynth::synth
