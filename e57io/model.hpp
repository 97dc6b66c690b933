#pragma once
// Conversions between the element tree and the plain model types of types.hpp: the standard's
// data3D / images2D / file-level structures. Unknown (extension) children are ignored here but
// stay available in the element tree. Throws Error naming the element path on a wrong type.

#include <string>

#include "e57io/element.hpp"
#include "e57io/types.hpp"

namespace coloc::e57 {

FileInfo file_info_from_element(const Element& root);
Data3D data3d_from_element(const Element& scan);
Image2D image2d_from_element(const Element& image);

// The reverse, for the writer. The points / blob children are added by the writer.
Element pose_to_element(const std::string& name, const Pose& pose);
Element datetime_to_element(const std::string& name, const DateTime& t);
Element data3d_to_element(const Data3D& scan);
Element image2d_to_element(const Image2D& image);  // without the blob elements

}  // namespace coloc::e57
