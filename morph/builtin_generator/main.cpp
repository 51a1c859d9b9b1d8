// facesynth_builtin_generator OUT.fsm: writes the built-in model as an .fsm file. The build runs it
// and embeds the file in the morph library, which builtin_model() then reads (morph/CMakeLists.txt).
#include "morph/builtin.h"
#include "morph/model_io.h"

#include <exception>
#include <iostream>

int main(int argc, char** argv) {
    if (argc != 2) {
        std::cerr << "usage: facesynth_builtin_generator OUT.fsm\n";
        return 2;
    }
    try {
        facesynth::morph::write_model(facesynth::morph::generate_builtin_model(), argv[1]);
    } catch (const std::exception& e) {
        std::cerr << "facesynth_builtin_generator: " << e.what() << '\n';
        return 1;
    }
    return 0;
}
