#pragma once
// Image dimensions from a file's header, read before decoding, so that a photograph too large to
// process is refused with a clear message instead of a multi-gigabyte decode. PNG, JPEG and BMP
// headers are understood; other formats are left to the decoder.
#include <cstdint>
#include <filesystem>
#include <optional>

namespace facesynth::core {

struct ImageDimensions {
    std::int64_t width = 0;
    std::int64_t height = 0;
};

// The dimensions a PNG, JPEG or BMP header declares; nullopt for other or unreadable files.
[[nodiscard]] std::optional<ImageDimensions> read_image_dimensions(const std::filesystem::path& path);

// Whether the file name has an image extension the tools read (.png .jpg .jpeg .bmp .tif .tiff
// .webp .ppm .pgm, any case): the one list used when a folder is scanned for images.
[[nodiscard]] bool is_image_file(const std::filesystem::path& path);

// Largest photograph `detect`, `eval landmarks` and `fit --image` accept (100 megapixels).
inline constexpr std::int64_t kMaxImagePixels = 100'000'000;

// Throws core::Error naming the file when its header declares more than `max_pixels` pixels.
void check_image_not_too_large(const std::filesystem::path& path, std::int64_t max_pixels = kMaxImagePixels);

}  // namespace facesynth::core
