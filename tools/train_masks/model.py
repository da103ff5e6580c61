"""The network: a compact encoder-decoder on camera-frame xyz (depth back-projected with
the intrinsics; 0 where depth is missing), optionally followed by the registered colour
(RGB scaled to [-0.5, 0.5]). Input [1, 3, H, W] or [1, 6, H, W] (H, W multiples of 16),
output [1, 2, H/2, W/2] logits: channel 0 = foreground (an object, not floor, wall or
table), channel 1 = instance boundary (an object pixel next to another object). The C++
decoder (OnnxInstanceSegmenter, "dense layout") recognises the layout by these shapes.
"""
import torch
import torch.nn as nn


def block(cin, cout, stride=1, dilation=1):
    return nn.Sequential(
        nn.Conv2d(cin, cout, 3, stride=stride, padding=dilation, dilation=dilation, bias=False),
        nn.BatchNorm2d(cout),
        nn.ReLU(inplace=True),
    )


class XyzInstanceNet(nn.Module):
    def __init__(self, width=(16, 24, 32, 48, 64), in_channels=3):
        super().__init__()
        c0, c1, c2, c3, c4 = width
        self.in_channels = in_channels
        self.stem = block(in_channels, c0, stride=2)                                 # H/2
        self.enc1 = block(c0, c1)                                          # H/2
        self.enc2 = nn.Sequential(block(c1, c2, stride=2), block(c2, c2))  # H/4
        self.enc3 = nn.Sequential(block(c2, c3, stride=2), block(c3, c3))  # H/8
        self.enc4 = nn.Sequential(block(c3, c4, stride=2), block(c4, c4, dilation=2),
                                  block(c4, c4, dilation=4))               # H/16, wide context
        self.up = nn.Upsample(scale_factor=2, mode="nearest")
        self.dec3 = block(c4 + c3, c3)
        self.dec2 = block(c3 + c2, c2)
        self.dec1 = block(c2 + c1, c1)
        self.head = nn.Conv2d(c1, 2, 1)

    def forward(self, xyz):
        s1 = self.enc1(self.stem(xyz))
        s2 = self.enc2(s1)
        s3 = self.enc3(s2)
        x = self.enc4(s3)
        x = self.dec3(torch.cat([self.up(x), s3], 1))
        x = self.dec2(torch.cat([self.up(x), s2], 1))
        x = self.dec1(torch.cat([self.up(x), s1], 1))
        return self.head(x)
