// libFuzzer target: the label-image readers (NIfTI through nifticlib, NRRD through teem;
// discretise/label_image), the format chosen by FASCIA_FUZZ_EXTENSION. An image is read, with
// as many labels as voxels, or refused with LabelImageError; anything else is a finding.
#include "discretise/label_image.hpp"
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = fascia::fuzz::scratch_file(data, size, FASCIA_FUZZ_EXTENSION);
  try {
    const fascia::LabelImage image = fascia::read_label_image(path);
    if (static_cast<long long>(image.labels.size()) != image.voxel_count())
      fascia::fuzz::finding(std::to_string(image.labels.size()) + " labels for " + std::to_string(image.voxel_count()) +
                            " voxels");
  } catch (const fascia::LabelImageError&) {
  } catch (const std::exception& e) {
    fascia::fuzz::finding(std::string("escaped exception: ") + e.what());
  }
  return 0;
}
