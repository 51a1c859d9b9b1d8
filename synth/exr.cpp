#include "synth/exr.h"

#include "core/error.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

namespace facesynth::synth {

std::string encode_depth_exr(const cv::Mat& depth, const std::string& context) {
    if (depth.type() != CV_32FC1 || !depth.isContinuous()) throw core::Error(context + ": depth map must be a continuous CV_32FC1 image");
    std::vector<unsigned char> bytes;
    OIIO::Filesystem::IOVecOutput proxy(bytes);
    auto output = OIIO::ImageOutput::create("openexr");
    if (!output) throw core::Error(context + ": OpenImageIO has no OpenEXR writer");
    OIIO::ImageSpec spec(depth.cols, depth.rows, 1, OIIO::TypeDesc::FLOAT);
    spec.channelnames = {"Z"};
    spec.attribute("compression", "zip");
    // OpenImageIO stamps the current time into the header (capDate) unless DateTime is given: an
    // empty one keeps sample i's file the same bytes in every run.
    spec.attribute("DateTime", "");
    output->set_ioproxy(&proxy);
    if (!output->open("depth.exr", spec) || !output->write_image(OIIO::TypeDesc::FLOAT, depth.ptr<float>()) || !output->close())
        throw core::Error(context + ": EXR encoding failed: " + output->geterror());
    return {bytes.begin(), bytes.end()};
}

}  // namespace facesynth::synth
