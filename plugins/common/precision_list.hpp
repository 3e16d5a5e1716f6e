// Shared by the MeshLab and CloudCompare plugins (both Qt): the core's precision values
// (nhnet::kPrecisions, the default first) as the list each plugin offers, and their help.
#pragma once

#include "nhnet/learned/nhnet_model.hpp"

#include <QString>
#include <QStringList>

namespace nhplugin {

/// nhnet::kPrecisions in their order: the MeshLab enum's labels, the CloudCompare list's items.
inline QStringList precision_list() {
  QStringList out;
  for (const char* p : nhnet::kPrecisions) out << p;
  return out;
}

/// The precision setting's help in both plugins (nhnet::kPrecisionHelp, as nhnet-cli's).
inline QString precision_help() {
  return QString("The network's arithmetic. ") + nhnet::kPrecisionHelp + ".";
}

}  // namespace nhplugin
