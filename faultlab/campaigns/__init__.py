"""faultlab.campaigns: campaign drivers that run several stores through the ordinary runner."""
