#include "core/image_header.h"

#include "core/error.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <fstream>
#include <string>
#include <string_view>

namespace facesynth::core {
namespace {

std::int64_t big_endian(const unsigned char* p, int bytes) {
    std::int64_t value = 0;
    for (int i = 0; i < bytes; ++i) value = (value << 8) | p[i];
    return value;
}

std::int64_t little_endian_signed32(const unsigned char* p) {
    const std::uint32_t u = static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
                            static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
    return static_cast<std::int32_t>(u);
}

// JPEG: markers FF xx with a 2-byte big-endian length, until a start-of-frame (SOF0-SOF15 except
// DHT C4, JPG C8 and DAC CC) gives precision, height and width.
std::optional<ImageDimensions> jpeg_dimensions(std::ifstream& in) {
    in.seekg(2);
    for (int markers = 0; markers < 1000; ++markers) {
        std::array<unsigned char, 4> head{};
        if (!in.read(reinterpret_cast<char*>(head.data()), 4)) return std::nullopt;
        if (head[0] != 0xFF) return std::nullopt;
        const unsigned char marker = head[1];
        const std::int64_t length = big_endian(head.data() + 2, 2);
        if (length < 2) return std::nullopt;
        if (marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC) {
            std::array<unsigned char, 5> frame{};
            if (!in.read(reinterpret_cast<char*>(frame.data()), 5)) return std::nullopt;
            return ImageDimensions{big_endian(frame.data() + 3, 2), big_endian(frame.data() + 1, 2)};
        }
        in.seekg(length - 2, std::ios::cur);
    }
    return std::nullopt;
}

}  // namespace

std::optional<ImageDimensions> read_image_dimensions(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::array<unsigned char, 26> head{};
    if (!in.read(reinterpret_cast<char*>(head.data()), head.size())) return std::nullopt;
    static constexpr std::array<unsigned char, 8> kPng = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    if (std::equal(kPng.begin(), kPng.end(), head.begin()) && std::string(head.begin() + 12, head.begin() + 16) == "IHDR")
        return ImageDimensions{big_endian(head.data() + 16, 4), big_endian(head.data() + 20, 4)};
    if (head[0] == 0xFF && head[1] == 0xD8) return jpeg_dimensions(in);
    if (head[0] == 'B' && head[1] == 'M') {
        const std::int64_t height = little_endian_signed32(head.data() + 22);
        return ImageDimensions{little_endian_signed32(head.data() + 18), height < 0 ? -height : height};
    }
    return std::nullopt;
}

void check_image_not_too_large(const std::filesystem::path& path, std::int64_t max_pixels) {
    const auto size = read_image_dimensions(path);
    if (size && size->width > 0 && size->height > 0 && size->width > max_pixels / size->height)
        throw file_error(path.string(), "image is " + std::to_string(size->width) + " x " + std::to_string(size->height) +
                                            " pixels, more than the " + std::to_string(max_pixels / 1'000'000) +
                                            " megapixels this tool accepts (resize it first)");
}

bool is_image_file(const std::filesystem::path& path) {
    static constexpr std::array<std::string_view, 9> kExtensions{".png", ".jpg", ".jpeg", ".bmp", ".tif",
                                                                 ".tiff", ".webp", ".ppm", ".pgm"};
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return std::find(kExtensions.begin(), kExtensions.end(), ext) != kExtensions.end();
}

}  // namespace facesynth::core
